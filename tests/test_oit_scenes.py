"""Opacity in scenes (the ``oit`` effect): Mesh.opacity and the content hash, the Mitsuba XML ``mask``
convention, the teapot / hairball / transparent dragon builders, and the yang2010 reproduction's data."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import SHARED_SCENES, SHARED_SKIP
from ldbench.core.errors import LdbenchError
from ldbench.core.mitsuba_xml import load_mitsuba_xml
from ldbench.core.scene import Mesh
from ldbench.core.scenes import load_scene
from testkit import cornell_like

TRI = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]]))


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), "0.5", True, None])
def test_opacity_is_validated(bad):
    with pytest.raises(LdbenchError, match="opacity"):
        Mesh("m", *TRI, (0.5, 0.5, 0.5), bad)


def test_content_hash_unchanged_for_opaque_scenes():
    """Hashes recorded before opacity existed (they key every cached reference): unchanged; any opacity
    below 1 changes the hash."""
    assert load_scene("cornell").content_hash() == "e9d229f12f2c88a6"
    assert load_scene("hairball").content_hash() == "2ac296c65c8550e2"
    assert load_scene("hairball", opacity=1.0).content_hash() == "2ac296c65c8550e2"
    assert cornell_like().content_hash() == "4feb7a28b3a6a38d"
    a, b = load_scene("hairball", opacity=0.5), load_scene("hairball", opacity=0.25)
    assert len({a.content_hash(), b.content_hash(), "2ac296c65c8550e2"}) == 3


def xml(tmp_path, bsdf: str) -> str:
    p = tmp_path / "s.xml"
    p.write_text(f"""<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform></sensor>
  <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8,0.1,0.1"/></bsdf>
  <shape type="rectangle">{bsdf}</shape>
  <shape type="cube"><transform name="to_world"><translate z="-3"/></transform></shape>
</scene>""")
    return str(p)


@pytest.mark.parametrize("bsdf,albedo,alpha,hash_", [  # hashes: those of the earlier hand-written XML parser
    ('<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>', 0.5, 0.3,
     "12c433f11d6a4255"),
    ('<bsdf type="mask"><float name="opacity" value="0.7"/><bsdf type="twosided"><ref id="red"/></bsdf></bsdf>',
     0.8, 0.7, "ecc891e64c996918"),
    ('<bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.2"/><ref id="red"/></bsdf></bsdf>',
     0.8, 0.2, "b1e6947cf2e4766f"),
    ('<bsdf type="mask"><bsdf type="diffuse"/></bsdf>', 0.5, 0.5, "3cfc6a9d9b0576b5"),  # Mitsuba's default opacity
    ('<ref id="red"/>', 0.8, 1.0, "85c8d53f3a5a3d12"),
])
def test_xml_mask_opacity(tmp_path, bsdf, albedo, alpha, hash_):
    sc = load_mitsuba_xml(xml(tmp_path, bsdf))
    assert sc.meshes[0].albedo[0] == pytest.approx(albedo) and sc.meshes[0].opacity == pytest.approx(alpha)
    assert sc.meshes[1].opacity == 1.0
    assert sc.content_hash() == hash_


@pytest.mark.parametrize("bsdf,words", [
    ('<bsdf type="mask"><rgb name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>', "<rgb> as mask opacity"),
    ('<bsdf type="mask"><float name="opacity" value="1.3"/><bsdf type="diffuse"/></bsdf>', "outside [0, 1]"),
    ('<bsdf type="mask"><texture type="bitmap" name="opacity"/><bsdf type="diffuse"/></bsdf>',
     "unsupported texture"),
    ('<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>',
     "nested mask"),
    ('<bsdf type="mask"><float name="opacity" value="0.3"/></bsdf>', "0 nested bsdfs"),
    ('<bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>'
     '<bsdf type="mask"><float name="opacity" value="0.6"/><bsdf type="diffuse"/></bsdf></bsdf>',
     "different front and back opacity"),
])
def test_xml_mask_errors_are_one_line(tmp_path, bsdf, words):
    with pytest.raises(LdbenchError) as e:
        load_mitsuba_xml(xml(tmp_path, bsdf))
    msg = str(e.value)
    assert words in msg and "\n" not in msg and "s.xml" in msg, msg


def test_teapot_is_closed_and_transparent():
    import trimesh

    sc = load_scene("teapot")
    assert [m.name for m in sc.meshes] == ["body", "spout", "handle"]
    assert {m.opacity for m in sc.meshes} == {0.5} and sc.params == {"segments": 48, "opacity": 0.5}
    for m in sc.meshes:
        t = trimesh.Trimesh(m.vertices, m.faces, process=False)
        assert t.is_watertight and t.is_winding_consistent and t.volume > 0, m.name
    assert 9000 < sc.triangle_count < 12000
    assert load_scene("teapot:segments=16,opacity=0.8").meshes[0].opacity == 0.8
    assert load_scene(sc.name, **sc.params).content_hash() == sc.content_hash()
    for bad in ({"opacity": 2}, {"opacity": "x"}, {"segments": 4}):
        with pytest.raises(LdbenchError, match="teapot"):
            load_scene("teapot", **bad)


def test_hairball_opacity_is_the_tubes():
    sc = load_scene("hairball", triangles=2000, opacity=0.3)
    assert {m.name: m.opacity for m in sc.meshes} == {"tubes": 0.3, "floor": 1.0}


def test_hairball_colours_split_the_same_tubes():
    """colours = n: tube i in mesh i mod n with palette colour i mod n, the same triangles; n = 1 is the
    one-colour scene, hash included (its cached references stay valid)."""
    from ldbench.core.scenes.hairball import PALETTE

    one = load_scene("hairball", triangles=6000, opacity=0.3)
    assert load_scene("hairball", triangles=6000, opacity=0.3, colours=1).content_hash() == one.content_hash()
    four = load_scene("hairball", triangles=6000, opacity=0.3, colours=4)
    assert [m.name for m in four.meshes] == ["tubes0", "tubes1", "tubes2", "tubes3", "floor"]
    assert [m.albedo for m in four.meshes[:4]] == [pytest.approx(c) for c in PALETTE[:4]]
    assert four.triangle_count == one.triangle_count and all(m.opacity == 0.3 for m in four.meshes[:4])
    tri = lambda m: {tuple(np.round(m.vertices[f].ravel(), 6)) for f in m.faces}  # noqa: E731
    assert set().union(*map(tri, four.meshes[:4])) == tri(one.meshes[0])
    # 66 vertices a tube (11 rings of 6): tube 1 opens tubes1
    assert np.array_equal(four.meshes[1].vertices[:66], one.meshes[0].vertices[66:132])
    assert four.content_hash() != one.content_hash()
    with pytest.raises(LdbenchError, match="colours"):
        load_scene("hairball", colours=9)


@pytest.mark.skipif(not (SHARED_SCENES / "stanford_dragon").is_dir(), reason=f"{SHARED_SKIP} (stanford_dragon)")
def test_transparent_dragon():
    sc = load_scene("transparent_dragon", opacity=0.4)
    assert sc.meshes[0].opacity == 0.4 and all(m.opacity == 1.0 for m in sc.meshes[1:])
    assert sc.triangle_count == load_scene("dragon").triangle_count
    assert sc.meshes[0].albedo == pytest.approx((0.15, 0.45, 0.75))


def test_transparent_dragon_not_fetched_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("LDBENCH_SCENES", str(tmp_path))
    with pytest.raises(LdbenchError, match="not fetched.*ldbench scenes fetch dragon"):
        load_scene("transparent_dragon")


def test_yang2010_published_numbers_and_rows():
    """Table 1 and §4.1.3 of yang2010 (docs/reference/methods/oit.md); every row is produced by the suite at both scales."""
    from ldbench.reports.reproduce import registry, scale_match, scale_suite, suite_file
    from ldbench.harness.suite import load_suite

    e = registry()["yang2010-table1"]
    rows = {r["id"]: r for r in e.rows}
    for rid, fps in (("teapot-ll", 743), ("teapot-dp", 579), ("dragon-ll", 338), ("dragon-dp", 45),
                     ("dragon-ddp", 94), ("cap-all", 112), ("cap-8", 153), ("cap-2", 165), ("cap-32", 129)):
        assert rows[rid]["time_ms"] == pytest.approx(1000.0 / fps, abs=1e-3), rid
    assert rows["cap-8"]["psnr"] == 13.5 and "time_ms" not in rows["teapot-ddp"]
    for scale in ("paper", "ci"):
        jobs = scale_suite(load_suite(suite_file(e)), e.scales[scale]).jobs
        for r in e.rows:
            m = scale_match(r["match"], e.scales[scale])
            assert any(j.scene == m["scene"] and j.method == m["method"]
                       and all(dict(j.params).get(k, 0) == v for k, v in m.get("params", {}).items())
                       and all(dict(j.scene_params).get(k) == v for k, v in m.get("scene_params", {}).items())
                       for j in jobs), (scale, r["id"])
