"""The structure spec (ldbench/methods/structures/spec.py) and its knobs that no single adapter test pins down."""
from __future__ import annotations

import dataclasses

import pytest

from ldbench.core.errors import LdbenchError
from ldbench.methods.gbuffer import SceneGeometry
from ldbench.methods.structures import StructureSpec, make_structure
from testkit import LAYER_H as H, LAYER_MESHES, LAYER_W as W, layer_transforms, quads_scene


def _tie_scene():
    """The quads plus a copy of ``c`` (the same triangles, later in the scene) with a darker albedo: its
    fragments tie with c's at equal depth, and its albedo word sorts before c's."""
    sc = quads_scene()
    c = next(m for m in LAYER_MESHES if m.name == "c")
    dark = dataclasses.replace(c, name="c_dark", albedo=(0.1, 0.1, 0.1))
    return dataclasses.replace(sc, meshes=list(sc.meshes) + [dark])


@pytest.mark.parametrize("source", ["raster", "splat", "peel"])
def test_canonical_orders_ties_by_payload(gpu, source):
    """``canonical``: fragments at equal depth in ascending payload order, whatever the source (the order
    that makes the peel and the single-pass LDIs bit-identical); the tie lists exist and are sorted."""
    res = gpu.resources()
    try:
        geo = SceneGeometry(gpu, _tie_scene(), res)
        spec = StructureSpec(layout="linear", source=source, payload=("albedo",), indexed=False, canonical=True)
        s = make_structure(spec, gpu, geo, res, layers=2, width=W, height=H, prefix=f"canon.{source}.")
        s.set_layers(*layer_transforms())
        s.build()
        ties = 0
        for layer in s.lists(payload=True):
            for row in layer:
                for lst in row:
                    for (z0, w0), (z1, w1) in zip(lst, lst[1:]):
                        assert z0 <= z1
                        if z0 == z1:
                            ties += 1
                            assert w0 <= w1, (z0, w0, w1)
        assert ties > 20
        assert s.invariants(s.stats()) == []
    finally:
        res.release()


def test_spec_refuses_what_no_layout_builds():
    for bad, match in (({"layout": "linked", "canonical": True}, "canonical"),
                       ({"layout": "linked", "source": "peel"}, "peel"),
                       ({"layout": "linear", "source": "peel", "pool": "lazy"}, "peel"),
                       ({"page_nodes": 3}, "page_nodes"), ({"payload": ("normal", "normal")}, "payload"),
                       ({"splat_batch": 0}, "splat_batch")):
        with pytest.raises(LdbenchError, match=match):
            StructureSpec(**bad)
    assert StructureSpec(payload=["normal"]).payload == ("normal",)


def test_peel_serves_no_fragment_pass(gpu):
    res = gpu.resources()
    try:
        geo = SceneGeometry(gpu, quads_scene(), res)
        s = make_structure(StructureSpec(layout="linear", source="peel", payload=("normal", "albedo")), gpu, geo,
                           res, layers=2, width=W, height=H, prefix="peelonly.")
        s.set_layers(*layer_transforms())
        with pytest.raises(LdbenchError, match="assembles"):
            s.fragment_pass({}, 1)
        s.build()
        counts = s.list_counts()
        assert s.stats()["peel_layers"] == counts.max() == 6 and counts.sum() == s.stats()["fragments"]
        s.free_scratch()
        assert not any(".peel." in k for k in s.memory()) and s.invariants(s.stats()) == []
    finally:
        res.release()
