"""``wboit``: weighted blended order-independent transparency (McGuire & Bavoil, *Weighted Blended
Order-Independent Transparency*, JCGT 2(2), 2013); effect ``oit``. An approximate OIT baseline engines ship
today: no per-pixel storage, no sort, one geometry pass.

Stages:

``accumulate``  ``accumulate.glsl``: the whole scene (both faces, no depth test) with additive blending
                into two RGBA32F targets: Σ c α w and Σ α w, and the revealage Π (1 − α) (accumulated as
                Σ −log(1 − α): one blend state serves both targets) with the fragment count.
``resolve``     ``resolve.glsl``: C = Σ c α w / Σ α w · (1 − Π(1 − α)) + Π(1 − α) · background.

Exact where every fragment of a pixel has one colour and one opacity (the weighted average is then that
colour and the revealage is exact); elsewhere the weights w(z, α) stand in for the order. docs/reference/methods/oit.md
has the measured error on the yang2010 scenes.

Parameters: ``ldbench methods wboit`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.oit import OITMethod, complexity_counters

WEIGHTS = {"eq7": 7, "eq8": 8, "eq9": 9, "eq10": 10, "constant": 0}


@dataclass(frozen=True)
class WBOITParams(ParamsBase):
    weight: str = param("eq7", "depth weight w(z, alpha): the paper's eq7, eq8 or eq9 (of the view depth), eq10 "
                        "(of the window depth), or constant (w = 1: the weighted average of Bavoil & Myers 2008)",
                        choices=tuple(WEIGHTS), paper="eq7 .. eq10")


class WBOIT(OITMethod):
    """One accumulation pass with weighted additive blending and one resolve."""

    name = "wboit"
    paper = "mcguire2013"
    Params = WBOITParams

    def resize(self, w, h):
        r, ctx = self.res, self.gpu.ctx
        self.accum = r.texture("oit.wb.accum", (w, h), 4, "f4")
        self.reveal = r.texture("oit.wb.revealage", (w, h), 4, "f4")
        for f in getattr(self, "_fbos", ()):
            f.release()
        self._fbos = [ctx.framebuffer([self.accum, self.reveal]), ctx.framebuffer([self.out])]

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx = self.gpu, self.gpu.ctx
        w, h = view.width, view.height
        self.output(w, h)
        acc, _, _, _ = self.camera_program(view, "accumulate.glsl", {"WEIGHT": WEIGHTS[self.params.weight]})
        res = gpu.program(self.shader("resolve.glsl"))
        geo_vao, full = self.geo.vao(acc), ctx.vertex_array(res, [])
        with gpu.stage("accumulate"):
            fbo = self._fbos[0]
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
            self.set_common_uniforms(acc, view)
            with gpu.blending((ctx.ONE, ctx.ONE)):
                geo_vao.render()
        with gpu.stage("resolve"):
            fbo = self._fbos[1]
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            self.accum.use(0)
            self.reveal.use(1)
            res["accum"].value, res["reveal"].value = 0, 1
            self.set_common_uniforms(res, view)
            full.render(vertices=3)
        geo_vao.release()
        full.release()
        reveal = self.reveal
        return self.result(lambda: {**complexity_counters(read_texture(reveal, 4)[..., 1]),
                                    "weight": self.params.weight})

    def release(self):
        for f in getattr(self, "_fbos", ()):
            f.release()
        self._fbos = []
        super().release()
