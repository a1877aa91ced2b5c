"""``alpha-blend``: plain alpha blending of the transparent fragments in submission order, no sorting;
effect ``oit``. The speed baseline of yang2010 (Fig. 4(a) "Alpha Blending", 322 fps: "using only standard
alpha blending and results in an incorrect image"): every OIT method pays at least its cost.

Stage:

``blend``  ``blend.glsl``: the whole scene (both faces, no depth test) in one raster pass with the
           fixed-function over operator, C ← α c + (1 − α) C, onto the background; a second target marks
           the pixels any fragment reached (the coverage mask).

Exact only where the fragments of a pixel arrive back to front (or share one colour and opacity); the
order is the geometry's (meshes in scene order, triangles in mesh order: what the rasterizer keeps per
pixel), so the exact reference (ldbench/references/oit.py) exposes every pixel where it is not.

No parameters.
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase
from ldbench.methods.base import Result
from ldbench.methods.oit import OITMethod


@dataclass(frozen=True)
class AlphaBlendParams(ParamsBase):
    pass


class AlphaBlend(OITMethod):
    """One raster pass with over blending in submission order (unsorted: the speed baseline)."""

    name = "alpha-blend"
    paper = "yang2010"
    Params = AlphaBlendParams

    def resize(self, w, h):
        self.cover = self.res.texture("oit.alpha.cover", (w, h), 1, "f4")
        for f in getattr(self, "_fbos", ()):
            f.release()
        ctx = self.gpu.ctx
        self._fbos = [ctx.framebuffer([self.out, self.cover]), ctx.framebuffer([self.out]),
                      ctx.framebuffer([self.cover])]

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx = self.gpu, self.gpu.ctx
        w, h = view.width, view.height
        self.output(w, h)
        prog, _, _, _ = self.camera_program(view, "blend.glsl")
        vao = self.geo.vao(prog)
        with gpu.stage("blend"):
            self._fbos[1].clear(*(float(x) for x in BACKGROUND), 0.0)  # the over operator starts from it
            self._fbos[2].clear(0.0, 0.0, 0.0, 0.0)
            fbo = self._fbos[0]
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            self.set_common_uniforms(prog, view)
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
            with gpu.blending((ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA)):
                vao.render()
        vao.release()
        out, cover = self.out, self.cover
        return Result(image=lambda: read_texture(out, 4)[..., :3].copy(),
                      mask=lambda: read_texture(cover, 1)[..., 0] > 0.5,
                      memory_bytes=self.res.by_buffer(), counters=lambda: {})

    def release(self):
        for f in getattr(self, "_fbos", ()):
            f.release()
        self._fbos = []
        super().release()
