"""Order-independent transparency (yang2010 §4.1): the exact reference against closed forms, the three
adapters (ll-oit, depth-peeling, dual-depth-peeling) against the reference to float precision on small
scenes with intersecting triangles, the tie rule, the first-n-layers variant, overflow, duplicate
triangles within a mesh (removed at scene load).

Every kernel broken once on purpose (an edit of the GLSL, then restored), each failing a behaviour test
here: the depth-only order (no tie rule) in oit/oit.glsl fails the tie-rule and slow-path tests; no insertion
sort, and transmittance T *= α, in resolve.glsl fail ``test_methods_equal_the_exact_reference`` and first-n
layers; the slow path taking an equal copy twice (i >= li) fails the slow path on ties (max_list = 1) and
first-n with max_list = 4; the first-n selection keeping the farthest fails first-n (n = 1); the first-n
slow path compositing every layer fails first-n with max_list = 4; depth peeling keeping the wrong side,
colour not premultiplied, no background transmittance; dual peeling's front transmittance, back-layer
flag, back alpha, final composite, and the fragment count (2 per fragment in count.glsl) each fail
``test_methods_equal_the_exact_reference``; duplicates kept at load, or matched only in one vertex order,
fail the duplicate tests."""
from __future__ import annotations

import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.core.effects.oit import BACKGROUND, composite
from ldbench.core.scene import Camera, Mesh, Scene
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View, get_method
from ldbench.references.oit import intersections, render_oit

METHODS = ("ll-oit", "depth-peeling", "dual-depth-peeling")
TOL = 1e-5  # float precision: measured ≤ 1.2e-7 on llvmpipe for every method and scene here


def tri(p, name, albedo, alpha):
    return Mesh(name, np.array(p, np.float32), np.array([[0, 1, 2]]), albedo, alpha)


def quad(z, x0, x1, y0, y1, name, albedo, alpha):
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], np.float32)
    return Mesh(name, v, np.array([[0, 1, 2], [0, 2, 3]]), albedo, alpha)


def intersecting_scene():
    """Three mutually intersecting semi-transparent triangles in front of an opaque one (no exact ties).
    The camera is placed so that no pixel centre of the W × H image lies within 0.01 px of an edge (the
    raster snaps vertices to 1/256 px; the reference does not)."""
    return Scene("intersecting", [
        tri([[-1, -1, -0.5], [1, -0.8, 0.6], [0, 1, 0.1]], "a", (0.9, 0.1, 0.1), 0.5),
        tri([[-1, 0.9, 0.5], [1, 0.7, -0.6], [0.1, -1, 0.0]], "b", (0.1, 0.8, 0.2), 0.6),
        tri([[-0.9, -0.2, -0.9], [0.9, -0.3, 0.9], [0.9, 0.4, -0.2]], "c", (0.2, 0.3, 0.9), 0.35),
        tri([[-1.2, -1.2, -1.0], [1.2, -1.2, -1.0], [0, 1.3, -1.0]], "back", (0.8, 0.8, 0.7), 1.0)],
        Camera((0.367, 0.2193, 4.0), (0.0, 0.0, 0.0), fov_y=40.0))


TIE_A, TIE_B = ((0.9, 0.2, 0.1), 0.25), ((0.1, 0.9, 0.1), 0.75)


def tie_scene():
    """Two coincident copies of one quad (meshes 1 and 2: different colour and opacity) between an opaque
    back quad and a front quad: the effect's tie rule puts mesh 1 in front."""
    return Scene("ties", [
        quad(0.0, -1.0, 1.0, -1.0, 1.0, "back", (0.2, 0.3, 0.9), 1.0),
        quad(0.5, -0.53, 0.71, -0.61, 0.43, "tie_a", *TIE_A),
        quad(0.5, -0.53, 0.71, -0.61, 0.43, "tie_b", *TIE_B),
        quad(1.0, -0.23, 0.37, -0.31, 0.83, "front", (0.9, 0.9, 0.2), 0.4)],
        Camera((0.11, 0.07, 4.0), (0.0, 0.0, 0.0), fov_y=40.0))


W, H = 40, 32


def stack_scene(n=12):
    """n overlapping quads at distinct depths, listed in shuffled depth order, with distinct colours and
    opacities: lists of 1 … n fragments (the first-n selection and the long-list paths). Their edges
    project onto pixel boundaries of the W × H image, half a pixel from every pixel centre."""
    rng = np.random.default_rng(7)
    zs = rng.permutation(np.linspace(-1.0, 1.0, n))
    t = np.tan(np.radians(35.0) / 2)
    ms = []
    for i, z in enumerate(zs):
        dist = 5.0 - z
        x0, x1, y0, y1 = 1 + 2 * i, W - 1 - (3 * i) % 7, 1 + i, H - 1 - (2 * i) % 5  # pixel boundaries
        X = lambda px: (px / W * 2 - 1) * t * (W / H) * dist  # noqa: E731
        Y = lambda py: (1 - py / H * 2) * t * dist  # noqa: E731
        ms.append(quad(z, X(x0), X(x1), Y(y1), Y(y0), f"q{i}", tuple(rng.uniform(0.05, 0.95, 3)),
                       float(rng.uniform(0.15, 0.6))))
    return Scene("stack", ms, Camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), fov_y=35.0))


@pytest.fixture(scope="module")
def scenes():
    return {"intersecting": intersecting_scene(), "teapot": load_scene("teapot", segments=12), "ties": tie_scene(),
            "stack": stack_scene()}


@pytest.fixture(scope="module")
def refs(scenes):
    return {k: render_oit(sc, W, H) for k, sc in scenes.items()}


def run(gpu, scene, method, size=(W, H), method_cls=None, **params):
    cls = method_cls or get_method(method)
    m = cls(cls.Params.from_dict(params))
    m.setup(gpu, scene)
    try:
        return m.frame(View(scene.camera, *size), Effect("oit")).resolve()
    finally:
        m.release()


def assert_matches(result, ref, what=""):
    err = np.abs(np.asarray(result.image) - ref.mean).max(axis=2)
    assert err.max() < TOL, f"{what}: max error {err.max():.3g} at {np.unravel_index(err.argmax(), err.shape)}"
    assert np.array_equal(result.mask, ref.mask), f"{what}: coverage differs"


# ---- the reference -----------------------------------------------------------------------------------

def pixel_of(scene, p, w=W, h=H):
    """(row, col) of the pixel whose centre ray passes closest to world point p."""
    o, d = scene.camera.primary_rays(w, h)
    v = np.asarray(p, float) - o[0]
    v /= np.linalg.norm(v)
    return np.unravel_index(int(np.argmax(d @ v)), (h, w))


def test_reference_is_the_closed_form_composite(refs, scenes):
    """Pixels of the tie scene against the formula: front quad, the coincident pair in mesh order (the tie
    rule: both are found, one Mitsuba scene per mesh), the opaque back; background = 1; depth counts."""
    sc, ref = scenes["ties"], refs["ties"]
    col = lambda i: (sc.meshes[i].albedo, sc.meshes[i].opacity)  # noqa: E731
    cases = {(0.0, 0.2, 1.0): [3, 1, 2, 0], (0.5, -0.45, 0.5): [1, 2, 0], (-0.8, 0.8, 0.0): [0]}
    for p, order in cases.items():
        y, x = pixel_of(sc, p)
        want = composite([col(i)[0] for i in order], [col(i)[1] for i in order])
        np.testing.assert_allclose(ref.mean[y, x], want, atol=1e-6, err_msg=str(p))
    y, x = pixel_of(sc, (3.0, 3.0, 0.0))
    assert not ref.mask[y, x] and np.all(ref.mean[y, x] == np.float32(BACKGROUND))
    assert ref.variance.max() == 0 and ref.meta["layers_max"] == 4
    hits = intersections(sc, W, H)
    assert hits.counts()[ref.mask].min() >= 1 and hits.counts().max() == 4


def test_reference_first_n_layers_and_tie_order(scenes):
    """max_layers = n composites the first n; swapping the tied meshes changes the image (order matters)."""
    sc = scenes["ties"]
    y, x = pixel_of(sc, (0.0, 0.2, 1.0))
    one = render_oit(sc, W, H, max_layers=2).mean[y, x]
    m = sc.meshes
    np.testing.assert_allclose(one, composite([m[3].albedo, m[1].albedo], [m[3].opacity, m[1].opacity]), atol=1e-6)
    swapped = Scene("ties", [m[0], m[2], m[1], m[3]], sc.camera)
    assert np.abs(render_oit(swapped, W, H).mean[y, x] - render_oit(sc, W, H).mean[y, x]).max() > 0.05


# ---- the methods against the reference ---------------------------------------------------------------

@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["intersecting", "teapot", "stack"])
def test_methods_equal_the_exact_reference(gpu, scenes, refs, method, name):
    r = run(gpu, scenes[name], method)
    assert_matches(r, refs[name], f"{method} on {name}")
    c = r.counters
    assert c["depth_complexity_max"] == refs[name].meta["layers_max"]
    assert c["fragments"] == refs[name].meta["fragments"]
    assert c["depth_complexity_mean"] == pytest.approx(refs[name].meta["layers_mean"], rel=1e-6)
    assert r.invariants == []
    if method == "depth-peeling":
        assert c["peel_passes"] == c["layers"] + 1 == refs[name].meta["layers_max"] + 1
        assert c["samples_per_pass"][-1] == 0
    if method == "dual-depth-peeling":  # ⌈L/2⌉ passes peel L layers, and one more finds nothing left
        assert c["peel_passes"] in (-(-c["depth_complexity_max"] // 2), -(-c["depth_complexity_max"] // 2) + 1)


@pytest.mark.parametrize("name", ["intersecting", "teapot", "stack"])
def test_dual_peeling_pass_through_equals_the_default(gpu, scenes, refs, name):
    """The original's pass-through (every fragment writes every target) and the default (front copied,
    fragments peeled earlier discarded) give the exact reference both, with the same passes."""
    a, b = run(gpu, scenes[name], "dual-depth-peeling", pass_through=True), run(gpu, scenes[name], "dual-depth-peeling")
    assert_matches(a, refs[name], f"pass-through on {name}")
    assert np.array_equal(np.asarray(a.image), np.asarray(b.image))
    assert a.counters["peel_passes"] == b.counters["peel_passes"]


def test_ll_oit_follows_the_tie_rule(gpu, scenes, refs):
    r = run(gpu, scenes["ties"], "ll-oit")
    assert_matches(r, refs["ties"], "ll-oit on coincident surfaces")


def test_peeling_keeps_one_of_coincident_surfaces(gpu, scenes, refs):
    """Documented limitation: to depth peeling coincident surfaces are one layer (the first to arrive, mesh 1
    on llvmpipe), so the result is the reference of the scene without mesh 2; dual peeling merges them."""
    sc = scenes["ties"]
    without = Scene("ties", [m for i, m in enumerate(sc.meshes) if i != 2], sc.camera)
    assert_matches(run(gpu, sc, "depth-peeling"), render_oit(without, W, H), "depth-peeling on ties")
    r = run(gpu, sc, "dual-depth-peeling")
    assert np.abs(r.image - refs["ties"].mean).max() > 0.05


def test_long_lists_take_the_exact_slow_path(gpu, scenes, refs):
    r = run(gpu, scenes["intersecting"], "ll-oit", max_list=1)
    assert_matches(r, refs["intersecting"], "ll-oit max_list=1")
    assert r.counters["slow_path_lists"] > 0
    for n in (1, 2):  # the slow path's tie rule: equal (depth, material) copies taken in list order, once each
        r = run(gpu, scenes["ties"], "ll-oit", max_list=n)
        assert_matches(r, refs["ties"], f"ll-oit max_list={n} on ties")
        assert r.counters["slow_path_lists"] > 0


@pytest.mark.parametrize("method,params", [("ll-oit", {}), ("ll-oit", {"max_list": 4}), ("depth-peeling", {})])
def test_first_n_layers(gpu, scenes, method, params):
    """The first n layers (n = 2: the resolve selects 2 places of lists longer than 8; n = 5: insertion
    sort; max_list = 4: lists longer than 4 take n minimum searches) against the reference's first n."""
    sc = scenes["stack"]
    assert render_oit(sc, W, H).meta["layers_max"] == 12
    for n in (1, 2, 5):
        r = run(gpu, sc, method, max_layers=n, **params)
        assert_matches(r, render_oit(sc, W, H, max_layers=n), f"{method} max_layers={n} {params}")
        assert r.invariants == []


@pytest.mark.parametrize("params", [{"pool": "count"}, {"pool": "lazy"}, {"pool": "grow", "pool_capacity": 8},
                                    {"aggregate_atomics": True}], ids=["count", "lazy", "grow-small", "aggregate"])
def test_ll_oit_pool_policies_and_aggregated_counter(gpu, scenes, refs, params):
    """Every pool policy (a counting pass; sized from the previous frame; grown from 8 nodes and rebuilt) and
    the per-subgroup aggregated node counter store every fragment: the composite equals the reference."""
    for name in ("intersecting", "stack"):
        cls = get_method("ll-oit")
        m = cls(cls.Params.from_dict(params, method="ll-oit"))  # earlier flat names
        m.setup(gpu, scenes[name])
        try:
            for _ in range(2):  # lazy sizes the second frame from the first
                r = m.frame(View(scenes[name].camera, W, H), Effect("oit")).resolve()
        finally:
            m.release()
        assert_matches(r, refs[name], f"ll-oit {params} on {name}")
        assert r.invariants == [] and r.counters["fragments_stored"] == refs[name].meta["fragments"]


def test_overflow_is_a_degraded_row(tmp_path):
    """A pool too small for the fragments: the row is degraded (the image lacks fragments)."""
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    suite = suite_from_dict({"suite": {"size": "24x24", "warmup": 0, "frames": 1},
                             "run": [{"scene": "teapot", "scene_params": {"segments": 8}, "effect": "oit",
                                      "methods": ["ll-oit"],
                                      "params": {"ll-oit": {"pool": "fixed", "pool_capacity": 40}}}]}, name="t")
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False)
    status = df["status"].iloc[0]
    assert status.startswith("degraded") and "not stored (pool overflow)" in status, status
    assert df["psnr"].iloc[0] < 40


def test_effect_declaration():
    e = Effect("oit")
    assert e.key() == {"effect": "oit"} and not e.spec.stochastic(e.params) and not e.needs_light()
    assert {get_method(m).name for m in METHODS} == set(METHODS)
    assert all("oit" in get_method(m).effects for m in METHODS)


# ---- coincident copies within one mesh: removed at scene load, one rule for methods and reference -------

def duplicates_scene():
    """The tie scene's quad as one semi-transparent mesh that lists its triangles more than once: an exact
    copy, a copy with its vertices rotated, one with the winding reversed, one through other vertex
    indices at the same positions (4 duplicates of 2 triangles), over the opaque back quad."""
    x0, x1, y0, y1, z = -0.53, 0.71, -0.61, 0.43, 0.5
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z], [x0, y0, z], [x1, y1, z]], np.float32)
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 2], [2, 3, 0], [0, 2, 1], [4, 5, 3]])
    glass = Mesh("glass", v, f, *TIE_A)
    back = quad(0.0, -1.0, 1.0, -1.0, 1.0, "back", (0.2, 0.3, 0.9), 1.0)
    return Scene("duplicates", [back, glass], Camera((0.11, 0.07, 4.0), (0.0, 0.0, 0.0), fov_y=40.0))


def test_duplicate_triangles_are_removed_once_for_every_method(gpu):
    """As listed, ll-oit composites the quad 3 times where the reference (one hit per surface along a ray)
    counts it once; without the duplicates every method equals the reference, and the scene says how
    many it dropped."""
    from ldbench.core.scene import duplicate_faces, without_duplicate_triangles

    sc = duplicates_scene()
    assert duplicate_faces(sc.meshes[1].vertices, sc.meshes[1].faces).tolist() == [False, False, True, True, True,
                                                                                   True]
    ref = render_oit(sc, W, H)
    assert np.abs(run(gpu, sc, "ll-oit").image - ref.mean).max() > 0.1  # the disagreement the rule removes
    clean = without_duplicate_triangles(sc)
    assert clean.triangle_count == sc.triangle_count - 4 and clean.meshes[0] is sc.meshes[0]
    assert clean.warnings == ["scene 'duplicates': 4 duplicate triangles removed (exact copies within one mesh; "
                              "'glass': 4): every method and the reference see each triangle once"]
    np.testing.assert_array_equal(render_oit(clean, W, H).mean, ref.mean)  # the reference's own rule
    for method in METHODS:
        assert_matches(run(gpu, clean, method), ref, f"{method} without duplicates")
    assert without_duplicate_triangles(clean) is clean  # nothing left: unchanged, no line


def test_a_loaded_mesh_with_duplicates_says_so_once(tmp_path, capsys):
    """A mesh file listing a triangle twice: loading removes the copy, the run prints one line on stderr."""
    from ldbench.harness.cli import main

    obj = tmp_path / "twice.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\nf 3 1 2\nf 1 3 2\n")
    sc = load_scene(str(obj))
    assert sum(len(m.faces) for m in sc.meshes if m.name == "twice") == 2
    assert len(sc.warnings) == 1 and "2 duplicate triangles removed" in sc.warnings[0]
    rc = main(["run", "--scene", str(obj), "--method", "ll-oit", "--effect", "oit", "--size", "8x8",
               "--warmup", "0", "--frames", "1", "--out", str(tmp_path / "run"), "--no-report", "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 0 and err.count("duplicate triangles removed") == 1, err


def test_duplicate_faces_against_a_set_of_sorted_triangles():
    """The vectorised rule against the plain one: a face repeats an earlier one when the set of its three
    vertex positions was seen before (−0 and +0 being one position)."""
    from ldbench.core.scene import duplicate_faces

    rng = np.random.default_rng(3)
    for _ in range(3):
        v = rng.integers(-1, 2, (30, 3)).astype(np.float32) * np.float32(0.5)
        v[::7] *= np.float32(-1.0)  # some −0
        f = rng.integers(0, 30, (500, 3))
        seen, want = set(), []
        for tri in f:
            key = tuple(sorted(tuple(float(x) + 0.0 for x in v[i]) for i in tri))
            want.append(key in seen)
            seen.add(key)
        assert duplicate_faces(v, f).tolist() == want
