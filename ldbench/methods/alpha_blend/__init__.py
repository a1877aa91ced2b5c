"""``alpha-blend``: plain alpha blending of the transparent fragments in submission order, no sorting;
effect ``oit``. The speed baseline of yang2010 (Fig. 4(a) "Alpha Blending", 322 fps: "using only standard
alpha blending and results in an incorrect image"): every OIT method pays at least its cost.

Stage:

``blend``  ``blend.glsl``: the whole scene (both faces, no depth test) in one raster pass with the
           fixed-function over operator, C ← α c + (1 − α) C, onto the background; a second target marks
           the pixels any fragment reached (the coverage mask). With ``opaque_first``: two raster passes,
           the opaque surfaces (α = 1) with the depth test and depth writes, then the transparent ones over
           them with the depth test and without depth writes (yang2010 §4.1 step 1, "render all opaque or
           background objects as usual, including depth testing": an engine's alpha blending).

Exact only where the transparent fragments of a pixel arrive back to front (or share one colour and
opacity), and, without ``opaque_first``, where no opaque surface arrives after a transparent one in front of
it; the order is the geometry's (meshes in scene order, triangles in mesh order: what the rasterizer keeps
per pixel), so the exact reference (ldbench/references/oit.py) exposes every pixel where it is not.

Parameters: ``ldbench methods alpha-blend`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Result
from ldbench.methods.oit import OITMethod


#: ``target`` → (moderngl dtype of the colour and coverage textures, numpy dtype read back, scale to [0, 1])
TARGETS = {"rgba32f": ("f4", np.float32, 1.0), "rgba8": ("f1", np.uint8, 1.0 / 255.0)}


@dataclass(frozen=True)
class AlphaBlendParams(ParamsBase):
    opaque_first: bool = param(False, "opaque surfaces first with a depth test, then the transparent ones over "
                                      "them (an engine's alpha blending); default: one pass in submission order")
    target: str = param("rgba32f", "format of the colour and coverage targets: rgba32f (32-bit float, as the "
                                   "other OIT methods' output) or rgba8 (8 bits per channel, a game engine's back "
                                   "buffer: every blend rounds to 1/255)", choices=tuple(TARGETS))


class AlphaBlend(OITMethod):
    """One raster pass with over blending in submission order (unsorted: the speed baseline)."""

    name = "alpha-blend"
    paper = "yang2010"
    Params = AlphaBlendParams

    def resize(self, w, h):
        dtype = TARGETS[self.params.target][0]
        if dtype == "f4":
            self.colour = self.out
        else:  # an 8-bit colour target in place of the shared RGBA32F output
            self.res.free("oit.output")
            self.out = self.colour = self.res.texture("oit.alpha.colour8", (w, h), 4, dtype)
        self.cover = self.res.texture("oit.alpha.cover", (w, h), 1, dtype)
        depth = self.res.depth_texture("oit.alpha.depth", (w, h)) if self.params.opaque_first else None
        for f in getattr(self, "_fbos", ()):
            f.release()
        ctx = self.gpu.ctx
        self._fbos = [ctx.framebuffer([self.colour, self.cover], depth), ctx.framebuffer([self.colour]),
                      ctx.framebuffer([self.cover])]

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx = self.gpu, self.gpu.ctx
        w, h = view.width, view.height
        self.output(w, h)
        passes = ("OPAQUE", "TRANSPARENT") if self.params.opaque_first else ("ALL",)
        progs = [self.camera_program(view, "blend.glsl", {f"BLEND_{k}": 1} if k != "ALL" else None)[0]
                 for k in passes]
        vaos = [self.geo.vao(prog) for prog in progs]
        with gpu.stage("blend"):
            fbo = self._fbos[0]
            if self.params.opaque_first:
                fbo.clear(depth=1.0)  # every attachment (the colours are cleared again below)
            self._fbos[1].clear(*(float(x) for x in BACKGROUND), 0.0)  # the over operator starts from it
            self._fbos[2].clear(0.0, 0.0, 0.0, 0.0)
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            ctx.disable(ctx.CULL_FACE)
            for k, prog, vao in zip(passes, progs, vaos):
                self.set_common_uniforms(prog, view)
                if k == "ALL":
                    ctx.disable(ctx.DEPTH_TEST)
                else:  # opaque: nearest wins (depth writes); transparent: over it, behind the opaque hidden
                    ctx.enable(ctx.DEPTH_TEST)
                    ctx.depth_func = "<"
                    fbo.depth_mask = k == "OPAQUE"
                with gpu.blending((ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA)):
                    vao.render()
            fbo.depth_mask = True
            ctx.disable(ctx.DEPTH_TEST)
        for vao in vaos:
            vao.release()
        colour, cover = self.colour, self.cover
        _, np_dtype, scale = TARGETS[self.params.target]

        def read(tex, c):
            return read_texture(tex, c, dtype=np_dtype).astype(np.float32) * np.float32(scale)

        return Result(image=lambda: read(colour, 4)[..., :3].copy(),
                      mask=lambda: read(cover, 1)[..., 0] > 0.5,
                      memory_bytes=self.res.by_buffer(), counters=lambda: {})

    def release(self):
        for f in getattr(self, "_fbos", ()):
            f.release()
        self._fbos = []
        super().release()
