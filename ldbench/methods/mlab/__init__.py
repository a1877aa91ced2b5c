"""``mlab``: multi-layer alpha blending (Salvi & Vaidyanathan, *Multi-Layer Alpha Blending*, I3D 2014);
effect ``oit``. A bounded k-buffer per pixel that stays sorted and, when full, merges its two farthest
layers: exact while a pixel has at most ``k`` fragments, an approximation beyond.

Stages:

``clear``    ``count.glsl`` (CLEAR): every pixel's k-buffer empty, its lock free.
``insert``   ``insert.glsl``: the whole scene (both faces, no depth test); each fragment inserts
             (c α, 1 − α) at its place in its pixel's layers (depth, then material: the effect's order) and,
             with k + 1 layers, merges the two farthest: (C_a + T_a C_b, T_a T_b). The read-modify-write is
             a per-pixel critical section (``sync``).
``resolve``  ``resolve.glsl``: the layers front to back over the background.

``sync``: ``interlock`` is the paper's pixel synchronization (GL_ARB_fragment_shader_interlock, ordered:
fragments of a pixel merge in primitive order, so the result is deterministic); ``spinlock`` takes a
per-pixel lock with ``atomicCompSwap`` (any GL 4.3; a bounded number of tries, a fragment that never gets
the lock is counted as ``lost`` and makes the row degraded; the merge order among a pixel's fragments is
the GPU's, and MLAB's compression depends on it: where a pixel has more than ``k`` fragments, two frames
may differ in colour, measured up to 0.11 at k = 3 on an NVIDIA H200, while the product of the layers'
transmittances is the same); ``auto`` = interlock where the GL has it, else spinlock. Mesa's llvmpipe has
no interlock; NVIDIA's driver has it.

Counters: ``fragments``, ``merges`` (fragments beyond k that were compressed), ``lost``, depth complexity
of the stored layers, ``sync`` (the mode used). Memory: k × 24 bytes per pixel plus 8 bytes of count and
lock.

Parameters: ``ldbench methods mlab`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.oit import OITMethod, complexity_counters

SYNCS = ("auto", "interlock", "spinlock")
MAX_SPIN = 1 << 16  # lock tries per fragment before it is counted as lost
INTERLOCK = "GL_ARB_fragment_shader_interlock"


@dataclass(frozen=True)
class MLABParams(ParamsBase):
    k: int = param(4, "layers stored per pixel: exact up to k fragments per pixel, beyond that the two "
                   "farthest layers are merged (the paper's MLAB4 is k = 4; it also measures 2 and 8)",
                   lo=1, hi=32, paper="2, 4, 8")
    sync: str = param("auto", "per-pixel critical section: interlock (fragment shader interlock, ordered), "
                      "spinlock (an atomic lock per pixel), or auto (interlock where the GL has it, else "
                      "spinlock)",
                      choices=SYNCS, paper="interlock (pixel synchronization)")


class MLAB(OITMethod):
    """A k-buffer per pixel, sorted on insertion, merging its two farthest layers when full."""

    name = "mlab"
    paper = "salvi2014"
    Params = MLABParams

    def setup(self, gpu, scene):
        super().setup(gpu, scene)
        has = INTERLOCK in gpu.ctx.extensions
        sync = self.params.sync
        if sync == "interlock" and not has:
            raise LdbenchError(f"mlab sync=interlock needs {INTERLOCK}, which this GL "
                               f"({gpu.ctx.info['GL_RENDERER']}) lacks: use sync=spinlock")
        self.sync = ("interlock" if has else "spinlock") if sync == "auto" else sync
        self.stats = self.res.buffer("oit.mlab.stats", reserve=16)
        self._fbos = []

    def resize(self, w, h):
        r, k = self.res, self.params.k
        n = w * h
        self.layers = r.buffer("oit.mlab.layers", reserve=16 * k * n)
        self.keys = r.buffer("oit.mlab.keys", reserve=8 * k * n)
        self.counts = r.buffer("oit.mlab.counts", reserve=4 * n)
        self.locks = r.buffer("oit.mlab.locks", reserve=4 * n)
        self.count_img = r.texture("oit.mlab.layer_count", (w, h), 1, "f4")
        self.dummy = r.texture("oit.mlab.raster_target", (w, h), 1, "f1")
        for f in self._fbos:
            f.release()
        self._fbos = [self.gpu.ctx.framebuffer([self.dummy]), self.gpu.ctx.framebuffer([self.out])]

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx, k = self.gpu, self.gpu.ctx, self.params.k
        w, h = view.width, view.height
        self.output(w, h)
        d = {"K": k, "SYNC": int(self.sync == "interlock"), "MAX_SPIN": MAX_SPIN}
        ins, _, _, _ = self.camera_program(view, "insert.glsl", d)
        res = gpu.program(self.shader("resolve.glsl"), {"K": k})
        clear = gpu.compute(self.shader("count.glsl"), {"CLEAR": 1})
        geo_vao, full = self.geo.vao(ins), ctx.vertex_array(res, [])
        groups = ((w * h + 63) // 64,)
        self.stats.write(np.zeros(4, np.uint32).tobytes())
        for buf, b in ((self.layers, B.MLAB_LAYERS), (self.keys, B.MLAB_KEYS), (self.counts, B.MLAB_COUNTS),
                       (self.locks, B.MLAB_LOCKS), (self.stats, B.MLAB_STATS)):
            buf.bind_to_storage_buffer(b)
        with gpu.stage("clear"):
            clear["size"].value = (w, h)
            clear.run(*groups)
            ctx.memory_barrier()
        with gpu.stage("insert"):
            fbo = self._fbos[0]
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            fbo.color_mask = (False, False, False, False)
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
            self.set_common_uniforms(ins, view)
            geo_vao.render()
            ctx.memory_barrier()
        with gpu.stage("resolve"):
            fbo = self._fbos[1]
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            self.set_common_uniforms(res, view)
            full.render(vertices=3)
        geo_vao.release()
        full.release()

        def counters():
            cnt = gpu.compute(self.shader("count.glsl"))
            cnt["size"].value = (w, h)
            self.counts.bind_to_storage_buffer(B.MLAB_COUNTS)
            self.locks.bind_to_storage_buffer(B.MLAB_LOCKS)
            self.count_img.bind_to_image(B.OUT_IMAGE, read=False, write=True)
            cnt.run(*groups)
            ctx.memory_barrier()
            fragments, lost, merges, _ = (int(x) for x in np.frombuffer(gpu.read(self.stats), np.uint32))
            c = complexity_counters(read_texture(self.count_img, 1)[..., 0])
            c["layers_stored"] = c.pop("fragments")
            return {**c, "fragments": fragments, "merges": merges, "lost": lost, "k": k, "sync": self.sync}

        def invariants(c):
            return [f"mlab: {c['lost']} fragments never got their pixel's lock"] if c["lost"] else []

        return self.result(counters, invariants)

    def release(self):
        for f in getattr(self, "_fbos", ()):
            f.release()
        self._fbos = []
        super().release()
