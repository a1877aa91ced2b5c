"""Built-in scenes (one module each in ldbench/core/scenes/), their validated parameters and the scene
dispatcher (ldbench/core/scenes/__init__.py). A scene from outside ldbench: tests/test_plugins.py."""
import time

import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Mesh, Scene, SpotLight
from ldbench.core.scenes import build_scene, builders, list_scenes, load_scene

from conftest import SHARED_SCENES as SHARED

BUNNY = SHARED / "stanford_bunny" / "bun_zipper_res4.ply"
DRAGON = SHARED / "stanford_dragon" / "dragon_vrip_res4.ply"
needs_bunny = pytest.mark.skipif(not BUNNY.exists(), reason="shared scenes not present (stanford_bunny)")
needs_dragon = pytest.mark.skipif(not DRAGON.exists(), reason="shared scenes not present (stanford_dragon)")


def first_hits(scene, origins, dirs, tmin=1e-4):
    """Nearest hit distance and face index per ray (Möller–Trumbore, numpy; small scenes only)."""
    v, f, _, _ = scene.merged()
    v = v.astype(np.float64)
    p0, e1, e2 = v[f[:, 0]], v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    best_t = np.full(len(dirs), np.inf)
    best_f = np.full(len(dirs), -1)
    for s in range(0, len(dirs), 64):
        o, d = origins[s:s + 64, None], dirs[s:s + 64, None]
        p = np.cross(d, e2)
        det = np.sum(e1 * p, -1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
        tv = o - p0
        u = np.sum(tv * p, -1) * inv
        q = np.cross(tv, e1)
        w = np.sum(d * q, -1) * inv
        t = np.sum(e2 * q, -1) * inv
        hit = ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > tmin)
        t = np.where(hit, t, np.inf)
        best_t[s:s + 64] = t.min(1)
        best_f[s:s + 64] = np.where(np.isfinite(t.min(1)), t.argmin(1), -1)
    return best_t, best_f


def lit_fraction(scene, w=32, h=24):
    """(fraction of pixels that hit geometry, fraction of those that the spot light reaches directly)."""
    o, d = scene.camera.primary_rays(w, h)
    t, fi = first_hits(scene, o, d)
    hit = np.isfinite(t)
    x = o[hit] + t[hit, None] * d[hit]
    light = scene.lights[0]
    lp = np.array(light.position)
    to_x = x - lp
    dist = np.linalg.norm(to_x, axis=1)
    cos = (to_x / dist[:, None]) @ light.direction()
    in_cone = light.falloff(cos) > 0
    st, _ = first_hits(scene, np.broadcast_to(lp, to_x.shape).copy(), to_x / dist[:, None])
    visible = st > dist * (1 - 1e-3)
    return hit.mean(), float(np.mean(in_cone & visible))


@pytest.mark.parametrize("name,params", [("cornell", {}), ("cornell", {"subdivide": 2}), ("atrium", {}),
                                         ("hairball", {}), ("atrium", {"triangles": 2000})])
def test_builders_build(name, params):
    sc = build_scene(name, **params)
    assert isinstance(sc, Scene) and sc.name == name
    assert sc.triangle_count > 0 and len(sc.lights) == 1
    v, f, mid, alb = sc.merged()
    assert np.all(np.isfinite(v)) and f.max() < len(v) and alb.min() >= 0 and alb.max() <= 1
    for k, val in params.items():
        assert sc.params[k] == val


def test_cornell_geometry():
    sc = load_scene("cornell")
    assert sc.triangle_count == 30
    assert load_scene("cornell", subdivide=2).triangle_count == 30 * 9
    lo, hi = sc.bounds()
    assert np.allclose(lo, [-1, 0, -1]) and np.allclose(hi, [1, 2, 1])
    names = {m.name: m for m in sc.meshes}
    assert names["left_wall"].albedo == pytest.approx((0.63, 0.065, 0.05))
    assert names["right_wall"].albedo == pytest.approx((0.14, 0.45, 0.091))
    assert names["floor"].albedo == pytest.approx((0.725, 0.71, 0.68))
    # walls face into the box (counter-clockwise from the inside)
    for n, inward in [("floor", (0, 1, 0)), ("ceiling", (0, -1, 0)), ("back_wall", (0, 0, 1)),
                      ("left_wall", (1, 0, 0)), ("right_wall", (-1, 0, 0))]:
        m = names[n]
        tri = m.vertices[m.faces]
        nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert np.all(nrm @ np.array(inward, np.float32) > 0), n
    # blocks: closed except the bottom, normals outwards
    for n in ("short_block", "tall_block"):
        m = names[n]
        tri = m.vertices[m.faces].astype(np.float64)
        nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        c = m.vertices.mean(0)
        assert np.all(np.sum(nrm * (tri.mean(1) - c), 1) > 0), n
    assert names["tall_block"].vertices[:, 1].max() == pytest.approx(1.2)
    assert names["short_block"].vertices[:, 1].max() == pytest.approx(0.6)


def test_cornell_red_wall_on_the_left():
    sc = load_scene("cornell")
    w, h = 64, 64
    o, d = sc.camera.primary_rays(w, h)
    rows = np.arange(h // 2 - 2, h // 2 + 3)
    left = rows * w + 6  # the image's left side (row 0 at the top, column 0 on the left)
    right = rows * w + w - 7
    names = [m.name for m in sc.meshes]
    _, _, mid, _ = sc.merged()
    tl, fl = first_hits(sc, o[left], d[left])
    tr, fr = first_hits(sc, o[right], d[right])
    assert np.all(fl >= 0) and np.all(fr >= 0)
    assert {names[mid[i]] for i in fl} == {"left_wall"}
    assert {names[mid[i]] for i in fr} == {"right_wall"}
    assert sc.meshes[names.index("left_wall")].albedo[0] > 0.5  # red


def test_cornell_spot_hits_the_floor():
    sc = load_scene("cornell")
    light = sc.lights[0]
    t, fi = first_hits(sc, np.array([light.position]), np.array([light.direction()]))
    _, _, mid, _ = sc.merged()
    assert sc.meshes[mid[fi[0]]].name == "floor"
    # most of the floor lies inside the cone
    g = np.linspace(-0.95, 0.95, 21)
    X, Z = np.meshgrid(g, g)
    pts = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    to = pts - np.array(light.position)
    cos = (to / np.linalg.norm(to, axis=1, keepdims=True)) @ light.direction()
    assert np.mean(light.falloff(cos) > 0) > 0.9


@pytest.mark.parametrize("name", ["atrium", "hairball"])
@pytest.mark.parametrize("target", [2000, 20000, 260000])
def test_triangle_targets(name, target):
    t0 = time.perf_counter()
    sc = load_scene(name, triangles=target)
    dt = time.perf_counter() - t0
    # atrium: within 2 % by construction (measured ≤ 1.93 %); hairball: whole tubes of 120 triangles,
    # so within 60 (measured 2.1 % at 2000)
    assert abs(sc.triangle_count - target) <= (0.02 * target if name == "atrium" else 60), sc.triangle_count
    assert dt < 2.0
    assert sc.params["triangles"] == target


def test_atrium_close_to_target_and_default():
    sc = load_scene("atrium")
    assert sc.params["triangles"] == 20000
    assert abs(sc.triangle_count - 20000) <= 0.02 * 20000
    assert abs(load_scene("atrium", triangles=300000).triangle_count - 300000) <= 0.02 * 300000
    lo, hi = sc.bounds()
    assert np.allclose(lo, [-15, 0, -7]) and np.allclose(hi, [15, 12, 7])
    # columns: normals point away from their axes
    cols = next(m for m in sc.meshes if m.name == "columns")
    tri = cols.vertices[cols.faces].astype(np.float64)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    cen = tri.mean(1)
    axis_x = np.round(cen[:, 0] / 3) * 3
    axis_z = np.sign(cen[:, 2]) * 4
    radial = np.stack([cen[:, 0] - axis_x, np.zeros(len(cen)), cen[:, 2] - axis_z], 1)
    assert np.all(np.sum(nrm * radial, 1) > 0)


def test_deterministic_and_hash_changes():
    for name, a, b in [("cornell", {}, {"subdivide": 1}), ("atrium", {}, {"triangles": 30000}),
                       ("hairball", {}, {"seed": 1}), ("hairball", {}, {"triangles": 10000})]:
        h1 = load_scene(name, **a).content_hash()
        assert h1 == load_scene(name, **a).content_hash()
        assert h1 != load_scene(name, **b).content_hash()


@pytest.mark.parametrize("spec,params,words", [
    ("nosuchscene", {}, ["unknown scene", "nosuchscene"]),
    ("cornell", {"colour": 1}, ["unknown parameter", "colour", "cornell"]),
    ("atrium", {"triangles": 10}, ["scene 'atrium'", "triangles", "below its minimum 2000"]),
    ("atrium", {"triangles": "many"}, ["scene 'atrium'", "triangles", "not a valid int"]),
    ("hairball", {"seed": -1}, ["scene 'hairball'", "seed", "below its minimum"]),
    ("hairball", {"opacity": 2}, ["scene 'hairball'", "opacity", "above its maximum"]),
    ("cornell", {"subdivide": 1.5}, ["scene 'cornell'", "subdivide", "not a valid int"]),
    ("cornell", {"subdivide": True}, ["scene 'cornell'", "subdivide", "not a valid int"]),
    ("teapot", {"segments": "2e4"}, ["scene 'teapot'", "segments", "above its maximum"]),
    ("mesh", {"path": "x.ply", "albedo": "1, 2"}, ["scene 'mesh'", "albedo", "1 or 3 numbers"]),
    ("transparent_dragon", {"albedo": 1.5}, ["scene 'transparent_dragon'", "albedo", "outside [0, 1]"]),
    ("/tmp/x.ply", {"colour": 1}, ["unknown parameter", "colour", "parameters: albedo"]),
    ("mesh", {}, ["mesh", "path"]),
    ("mesh", {"path": "/nonexistent/dragon.ply"}, ["cannot read mesh", "/nonexistent/dragon.ply"]),
    ("/nonexistent/bunny.ply", {}, ["cannot read mesh", "/nonexistent/bunny.ply"]),
    ("cornell:subdivide", {}, ["key=value"]),
])
def test_bad_input(spec, params, words):
    with pytest.raises(LdbenchError) as e:
        load_scene(spec, **params)
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_unreadable_mesh(tmp_path):
    p = tmp_path / "junk.ply"
    p.write_bytes(b"this is not a ply file\n\x00\x01")
    with pytest.raises(LdbenchError, match="cannot read mesh"):
        load_scene(str(p))


def test_inline_params_and_string_values():
    a = load_scene("cornell:subdivide=2")
    b = load_scene("cornell", subdivide="2")
    assert a.triangle_count == b.triangle_count == 270
    assert a.params == {"subdivide": 2, "blocks": True}
    assert a.content_hash() == b.content_hash()


def test_the_empty_cornell_box_and_registered_views():
    """cornell:blocks=false is the box without its two blocks (10 of 30 triangles, another content hash); a
    registered scene's view swaps its camera and is recorded in the scene's params; any other parameter of a
    registered scene, or an unknown view, is one error line (checked before the scene's files are read)."""
    full, empty = load_scene("cornell"), load_scene("cornell:blocks=false")
    assert (full.triangle_count, empty.triangle_count) == (30, 10) and empty.params["blocks"] is False
    assert full.content_hash() != empty.content_hash()
    with pytest.raises(LdbenchError, match="takes only the parameter view"):
        load_scene("sponza:triangles=5")
    with pytest.raises(LdbenchError, match="has no view 'attic'.*views: corridor"):
        load_scene("sponza:view=attic")


@pytest.mark.parametrize("value", [20000, "20000", "20_000", 20000.0, "2e4", "20000.0", np.int64(20000)])
def test_an_integer_parameter_in_every_spelling_a_suite_or_command_line_gives(value):
    """TOML and ``--scene-set`` give an integral number as an int, a float or text: the same scene."""
    sc = load_scene("atrium", triangles=value)
    assert sc.params == {"triangles": 20000} and type(sc.params["triangles"]) is int
    assert sc.content_hash() == load_scene("atrium").content_hash()


def test_colours_in_every_spelling():
    from ldbench.core.scenes.base import rgb_value

    for v in ("0.7, 0.6, 0.5", "0.7 0.6 0.5", [0.7, 0.6, 0.5], (0.7, 0.6, 0.5), np.array([0.7, 0.6, 0.5])):
        assert rgb_value("albedo", v) == (0.7, 0.6, 0.5)
    assert rgb_value("albedo", 0.5) == rgb_value("albedo", "0.5") == (0.5, 0.5, 0.5)


def test_every_builtin_scene_is_its_own_module():
    """Discovered from ldbench/core/scenes/, one module per scene, named as the scene."""
    reg = builders()
    assert set(reg) == {"cornell", "atrium", "hairball", "mesh", "teapot", "transparent_dragon", "city"}
    for name, cls in reg.items():
        assert cls.__module__ == f"ldbench.core.scenes.{name}", cls


@needs_bunny
def test_mesh_scene_bunny():
    sc = load_scene(str(BUNNY), albedo="0.7, 0.6, 0.5")
    assert sc.name == "bun_zipper_res4"
    bunny = sc.meshes[0]
    # the file's 948 triangles hold 40 exact copies of others, removed on loading (one warning line)
    assert len(bunny.faces) == 948 - 40 and any("40 duplicate triangles" in w for w in sc.warnings)
    assert bunny.albedo == pytest.approx((0.7, 0.6, 0.5))
    lo, hi = bunny.vertices.min(0), bunny.vertices.max(0)
    assert lo[1] == pytest.approx(0, abs=1e-6) and (hi - lo).max() == pytest.approx(1, abs=1e-5)
    assert abs(lo[0] + hi[0]) < 1e-5 and abs(lo[2] + hi[2]) < 1e-5
    assert sc.params["path"] == str(BUNNY)
    same = load_scene("mesh", path=str(BUNNY), albedo=(0.7, 0.6, 0.5))
    assert same.content_hash() == sc.content_hash()
    assert load_scene("mesh", path=str(BUNNY)).content_hash() != sc.content_hash()


@needs_dragon
def test_mesh_scene_dragon():
    sc = load_scene("mesh", path=str(DRAGON))
    assert len(sc.meshes[0].faces) > 10000
    lo, hi = sc.meshes[0].vertices.min(0), sc.meshes[0].vertices.max(0)
    clip = (sc.camera.projection_matrix(1.0, 0.01, 100.0) @ sc.camera.view_matrix()
            @ np.append((lo + hi) / 2, 1.0))
    assert clip[3] > 0 and np.all(np.abs(clip[:2] / clip[3]) < 0.5)


def _scenes_for_camera_checks():
    out = [load_scene("cornell"), load_scene("atrium", triangles=2000), load_scene("hairball", triangles=2000)]
    if BUNNY.exists():
        out.append(load_scene(str(BUNNY)))
    return out


def test_camera_sees_the_scene():
    for sc in _scenes_for_camera_checks():
        lo, hi = sc.bounds()
        c = (lo + hi) / 2
        V = sc.camera.view_matrix()
        P = sc.camera.projection_matrix(4 / 3, 0.01, 1000.0)
        clip = P @ V @ np.append(c, 1.0)
        ndc = clip[:3] / clip[3]
        assert clip[3] > 0 and np.all(np.abs(ndc[:2]) < 0.9), sc.name
        hit, lit = lit_fraction(sc)
        assert hit > 0.4, (sc.name, hit)  # the camera looks at geometry, not at the void


def test_spot_light_lights_most_of_the_view():
    for sc in _scenes_for_camera_checks():
        hit, lit = lit_fraction(sc)
        # visible surfaces in the cone and unshadowed (cornell: the ceiling and the wall tops are
        # lit only indirectly, the blocks cast shadows)
        assert lit > 0.35, (sc.name, lit)
        light = sc.lights[0]
        assert abs(np.dot(light.direction(), np.array(light.up)) / np.linalg.norm(light.up)) < 0.99


def test_list_scenes():
    rows = {r["name"]: r for r in list_scenes()}
    assert set(rows) == {"cornell", "atrium", "hairball", "mesh", "teapot", "transparent_dragon", "city"}
    assert rows["atrium"]["parameters"] == {"triangles": 20000}
    assert rows["hairball"]["parameters"] == {"triangles": 20000, "seed": 0, "opacity": 1.0, "colours": 1}
    assert rows["cornell"]["parameters"] == {"subdivide": 0, "blocks": True}
    assert rows["mesh"]["parameters"] == {"path": "", "albedo": [0.8, 0.8, 0.8]}
    assert all(r["description"] and "\n" not in r["description"] for r in rows.values())
    assert "triangle count" in rows["atrium"]["table"] and "2000 … 4000000" in rows["atrium"]["table"]


def test_xml_dispatch():
    p = SHARED / "cornell_box_mitsuba3" / "classic" / "cbox.xml"
    if not p.exists():
        pytest.skip("shared scenes not present (cornell_box_mitsuba3)")
    sc = load_scene(str(p), res=64)
    assert sc.source == str(p) and sc.params["film"] == (64, 64)


def test_hairball_tubes_face_outwards_and_stay_in_the_box():
    sc = load_scene("hairball", triangles=20000, seed=3)
    tubes = next(m for m in sc.meshes if m.name == "tubes")
    v = tubes.vertices.astype(np.float64)
    ring_centre = np.repeat(v.reshape(-1, 6, 3).mean(1), 6, axis=0)  # 6 vertices per ring
    out = (v - ring_centre)[tubes.faces].mean(1)
    tri = v[tubes.faces]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.sum(nrm * out, 1) > 0)  # no folded or inside-out tube
    assert np.abs(v).max() < 1.0
    assert (sc.triangle_count - 2) % 120 == 0  # 120 triangles per tube + the floor
    assert sc.params == {"triangles": 20000, "seed": 3, "opacity": 1.0, "colours": 1}


@pytest.mark.parametrize("name,params", [("cornell", {"subdivide": 1}), ("atrium", {"triangles": 5000}),
                                         ("hairball", {"triangles": 3000, "seed": 7})])
def test_params_rebuild_the_scene(name, params):
    sc = load_scene(name, **params)
    assert load_scene(sc.name, **sc.params).content_hash() == sc.content_hash()


@pytest.mark.parametrize("make,words", [
    (lambda: Mesh("m", [[0, 0, 0], [1e39, 0, 0], [0, 1, 0]], [[0, 1, 2]]), "beyond"),  # finite in float64 only
    (lambda: Mesh("m", [[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]], [[0, 1, 2]]), "not finite"),
    (lambda: Mesh("m", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (1.5, 0.5, 0.5)), "albedo"),
    (lambda: Mesh("m", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (-0.1, 0.5, 0.5)), "albedo"),
    (lambda: Mesh("m", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (np.nan, 0.5, 0.5)), "albedo"),
    (lambda: SpotLight((0, 1, 0), (0, 0, 0), intensity=(-5, 5, 5)), "negative"),
    (lambda: SpotLight((0, 1, 0), (0, 0, 0), intensity=(np.nan, 5, 5)), "intensity"),
    (lambda: SpotLight((0, 1, 0), (0, 0, 0), intensity=(1e39, 5, 5)), "intensity"),
    (lambda: SpotLight((0, 1e39, 0), (0, 0, 0)), "position"),
    (lambda: Camera((0, 0, 1e39), (0, 0, 0)), "origin"),
    (lambda: Camera((0, 0, 4), (0, 0, 0), fov_y=float("nan")), "fov_y"),
])
def test_values_the_gpu_cannot_hold_or_physics_forbids(make, words):
    """Checked on the Scene objects, whatever built them (a builder, an XML loader): one line, and no
    numpy overflow warning on the way."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(LdbenchError, match=words):
            make()


def test_large_but_float32_safe_coordinates_are_kept():
    m = Mesh("m", [[0, 0, 0], [1e17, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    assert m.vertices.dtype == np.float32 and m.vertices[1, 0] == np.float32(1e17)
    assert SpotLight((0, 1, 0), (0, 0, 0), intensity=(0, 0, 0)).intensity == (0.0, 0.0, 0.0)
