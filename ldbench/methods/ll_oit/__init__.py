"""``ll-oit``: order-independent transparency with per-pixel linked lists (yang2010 §3, §4.1); effect ``oit``.

Per frame (stages):

``build``    (``count`` first with ``pool = "count"``) one raster pass of the whole scene (both faces, no
             depth test) into one layer of ``width × height`` linked lists of the shared module
             (:func:`ldbench.methods.structures.make_structure`, ``layout = "linked"``, ``layers = 1``): yang2010's insert — a node
             from the atomic counter, ``atomicExchange`` on the pixel's head — with one payload word per
             node, the fragment's material id. The layer's transform is the camera's clip matrix and its
             depth row the linear view depth (:func:`ldbench.methods.oit.camera_transform`). The lists stay in
             arrival order (no sort pass: the resolve sorts).
``resolve``  one full-screen pass (``resolve.glsl``): per pixel, walk the list into a register array,
             insertion-sort it by (depth, material) — the effect's tie rule — and composite front to back
             over the background (yang2010 §4.1 step 3). A list longer than ``max_list`` is composited
             exactly by repeated minimum search over the list (O(n²); counted as ``slow_path_lists``).

First n layers (yang2010 §4.1.1, §4.1.3): ``max_layers = n`` composites only the n nearest fragments over
the background — fragments behind them are dropped, the paper's accuracy-for-speed trade (8 of 64 layers:
−13.5 dB, 36 % faster on the mecha). The saving is in the sort: a list of L > 4n fragments has only its
first n places selected (~nL steps instead of insertion sort's ~L²/4), and a list longer than
``max_list`` needs only n minimum searches.

Payload: the material id, not the paper's packed RGBA8 colour: the colour and opacity come from the
material table in float32, so the composite matches the exact reference to float precision (RGBA8
would quantize each layer's colour by 1/255). The node is 12 bytes either way (depth, next, one word).

Counters: ``fragments`` (rasterized), ``fragments_stored``, ``overflow``, ``depth_complexity_max`` /
``depth_complexity_mean`` (list lengths; mean over non-empty lists), ``pixels_covered``,
``pool_capacity``, ``build_passes``, ``slow_path_lists``. Invariants (a violation makes the row
``degraded``): every fragment stored — pool overflow is reported even with ``pool = "fixed"``, because a
lost fragment changes the image — every stored node reachable once, no abandoned insert.

Parameters: ``ldbench methods ll-oit`` (docs/reference/parameters.md); the earlier flat names
(``max_layers``, ``pool``, ``aggregate_atomics``, ...) still work (:attr:`LLOITParams.renamed`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.params import ParamsBase, group, param
from ldbench.methods.invariants import layered_invariants
from ldbench.methods.structures import StructureSpec, make_structure
from ldbench.methods.oit import OITMethod, camera_transform


@dataclass(frozen=True)
class LLOITResolve(ParamsBase):
    """The ``oit`` effect's resolve (``oit.``)."""

    prefix = "oit."
    max_layers: int = param(0, "composite only the n nearest fragments of each pixel (0 = all: exact)", lo=0, hi=256,
                            paper="all (Table 1); 8 of 64 (§4.1.3)")
    max_list: int = param(64, "length of the register array of the resolve's insertion sort (longer lists take an "
                          "exact O(n^2) path in global memory)",
                          lo=1, hi=256)


@dataclass(frozen=True)
class LLOITParams(ParamsBase):
    # yang2010's lists: one layer, the material id per node, arrival order (the resolve sorts)
    structure: StructureSpec = group(StructureSpec, "one layer of per-pixel linked lists (yang2010's insert)",
                                     expose=("pool", "pool_capacity", "aggregate"), layout="linked",
                                     payload=("material",), sorted_insert=False)
    oit: LLOITResolve = group(LLOITResolve, "effect oit: the per-pixel sort and composite")

    renamed = {"max_layers": "oit.max_layers", "max_list": "oit.max_list", "pool": "structure.pool",
               "pool_capacity": "structure.pool_capacity", "aggregate_atomics": "structure.aggregate"}


class LLOIT(OITMethod):
    """yang2010's linked-list OIT: unsorted insert, per-pixel sort and composite in one resolve pass."""

    name = "ll-oit"
    paper = "yang2010"
    Params = LLOITParams
    params: LLOITParams

    def setup(self, gpu, scene):
        super().setup(gpu, scene)
        self.ls = None
        self.counters_buf = self.res.buffer("oit.ll.resolve_counters", reserve=16)
        self.fbo = self.vao = None

    def resize(self, w, h):
        p = self.params
        if self.ls is not None:
            self.ls.fbo.release()
            self.fbo.release()
        self.ls = make_structure(p.structure, self.gpu, self.geo, self.res, layers=1, width=w, height=h,
                                 prefix="oit.ll.")
        self.fbo = self.gpu.ctx.framebuffer([self.out])

    def _program(self):
        p = self.params
        d = {**self.ls.defines(), "OIT_ARRAY": p.oit.max_list}
        if p.oit.max_layers:
            d["OIT_FIRST_N"] = p.oit.max_layers
        return self.gpu.program(self.shader("resolve.glsl"), d)

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx = self.gpu, self.gpu.ctx
        self.output(view.width, view.height)
        clip, row, _, _ = camera_transform(self.geo, view)
        self.ls.set_layers(clip[None], row[None])
        self.ls.build(sort=False)
        prog = self._program()
        vao = ctx.vertex_array(prog, [])
        self.counters_buf.write(np.zeros(4, np.uint32).tobytes())
        with gpu.stage("resolve"):
            self.fbo.use()
            self.fbo.viewport = (0, 0, view.width, view.height)
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
            self.set_common_uniforms(prog, view)
            self.ls.bind()
            self.counters_buf.bind_to_storage_buffer(B.OIT_COUNTERS)
            vao.render(vertices=3)
        vao.release()
        return self.result(self._counters, self._invariants)

    def release(self):
        if getattr(self, "ls", None) is not None:
            self.ls.fbo.release()
            self.fbo.release()
            self.ls = None
        super().release()

    def _counters(self) -> dict:
        st = self.ls.stats()
        slow = int(np.frombuffer(self.gpu.read(self.counters_buf), np.uint32)[0])
        return {"fragments": st["fragments"], "fragments_stored": st["fragments_stored"],
                "overflow": st["overflow"], "depth_complexity_max": st["max_list_length"],
                "depth_complexity_mean": st["mean_list_length"], "pixels_covered": st["lists_nonempty"],
                "linked_nodes": st["linked_nodes"], "insert_failures": st["insert_failures"],
                "pool_capacity": st["pool_capacity"], "build_passes": st["build_passes"],
                "slow_path_lists": slow, "max_layers": self.params.oit.max_layers}

    def _invariants(self, c: dict) -> list[str]:
        # the lists are unsorted by design (yang2010): the resolve sorts, so "sorted" is not an invariant here
        return layered_invariants(self.ls, {**c, "unsorted_lists": 0})
