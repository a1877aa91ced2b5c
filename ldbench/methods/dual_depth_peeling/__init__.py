"""``dual-depth-peeling``: dual depth peeling (Bavoil & Myers 2008, "Order independent transparency with dual
depth peeling", NVIDIA), a baseline of yang2010 Table 1; effect ``oit``.

Per frame (stages repeat and add up):

``minmax``  one geometry pass, MAX blending of (−z, z) into an RG32F target: each pixel's depth interval.
``peel``    ``peel.glsl``: one geometry pass peels the nearest *and* the farthest layer left at every pixel
            (the interval read from the previous pass; two RG32F, two front RGBA32F targets ping-pong; all
            targets blend with MAX; fragments outside the interval are discarded): the nearest is composited front to back into the front accumulation
            (C, 1 − T), the farthest written to a back-layer target, and the fragments strictly inside the
            interval write the next interval.
``blend``   ``blend.glsl``: a full-screen pass blends the back layer over the back accumulation (which
            starts as the background), back to front, inside a ``samples_passed`` occlusion query; when the
            query reads zero every layer is peeled (Bavoil & Myers' loop condition).
``final``   C_front + T_front · back.

So ⌈L/2⌉ peel passes for L layers instead of depth peeling's L (+ the min-max pass). Depth: the linear view
depth in float32 — no depth buffer, no quantization — but fragments at exactly equal depth are peeled
together and merge (MAX blending), so coincident surfaces (the effect's ties) are not composited correctly,
as in the original algorithm.

Counters: ``peel_passes`` (geometry passes after the min-max pass), ``geometry_passes`` (all),
``samples_per_pass`` (back layers blended per pass), ``depth_complexity_max`` / ``depth_complexity_mean`` /
``fragments`` / ``pixels_covered`` from an untimed fragment-counting raster of the same view (additive
blending). Invariant: peeling ended because the query read zero, not at the safety cap.

Parameters: ``ldbench methods dual-depth-peeling`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.oit import PeelingMethod, complexity_counters

MAX_PASSES = 4096
FAR = 3.0e38


@dataclass(frozen=True)
class DualDepthPeelingParams(ParamsBase):
    pass_through: bool = param(False, "the original's pass-through: every fragment of the scene writes all "
                               "three targets in every pass and the front target is cleared; false: the front target "
                               "starts as a copy of the previous one and fragments peeled earlier are discarded (the "
                               "same output: MAX over the same values; docs/reference/methods/oit.md)")


class DualDepthPeeling(PeelingMethod):
    """Bavoil & Myers' dual depth peeling: nearest and farthest layer per geometry pass."""

    name = "dual-depth-peeling"
    paper = "yang2010"
    Params = DualDepthPeelingParams

    def resize(self, w, h):
        r, ctx = self.res, self.gpu.ctx
        self.depth_init = r.texture("oit.ddp.depth_init", (w, h), 2, "f4")
        self.depth = [r.texture(f"oit.ddp.depth{i}", (w, h), 2, "f4") for i in range(2)]
        self.front = [r.texture(f"oit.ddp.front{i}", (w, h), 4, "f4") for i in range(2)]
        self.back_layer = r.texture("oit.ddp.back_layer", (w, h), 4, "f4")
        self.back = r.texture("oit.ddp.back", (w, h), 4, "f4")
        fb = ctx.framebuffer
        self.init_fbo = fb([self.depth_init])
        self.peel_fbo = [fb([self.depth[i], self.front[i], self.back_layer]) for i in range(2)]
        self.clear_fbos = {"front1": fb([self.front[1]]), "back_layer": fb([self.back_layer]),
                           "depth0": fb([self.depth[0]]), "depth1": fb([self.depth[1]]),
                           "front0": fb([self.front[0]])}
        self.back_fbo = fb([self.back])
        self.final_fbo = fb([self.out])
        self.own(self.init_fbo, *self.peel_fbo, *self.clear_fbos.values(), self.back_fbo, self.final_fbo)
        self._w, self._h = w, h

    def _clear(self, fbo, *rgba):
        fbo.use()
        fbo.viewport = (0, 0, self._w, self._h)
        fbo.clear(*rgba)

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx = self.gpu, self.gpu.ctx
        w, h = view.width, view.height
        self.output(w, h)
        through = self.params.pass_through
        peel, clip, _, _ = self.camera_program(view, "peel.glsl", {"DDP_PASS_THROUGH": 1} if through else None)
        blend = gpu.program(self.shader("blend.glsl"))
        final = gpu.program(self.shader("blend.glsl"), {"DDP_FINAL": 1})
        peel["depth_prev"].value, peel["front_prev"].value = 0, 1
        blend["back_layer"].value = 2
        final["front"].value, final["back"].value, final["depth_init"].value = 3, 4, 5
        geo_vao = self.geo.vao(peel)
        full, full_final = ctx.vertex_array(blend, []), ctx.vertex_array(final, [])
        ctx.disable(ctx.CULL_FACE | ctx.DEPTH_TEST)
        self.set_common_uniforms(peel, view)
        with gpu.stage("minmax"):
            self._clear(self.init_fbo, -FAR, -FAR, 0.0, 0.0)
            self._clear(self.clear_fbos["front1"], 0.0, 0.0, 0.0, 0.0)
            self._clear(self.back_fbo, *BACKGROUND, 0.0)
            self.init_fbo.use()
            ctx.enable(ctx.BLEND)
            ctx.blend_equation = ctx.MAX
            peel["init"].value = 1
            geo_vao.render()
        samples, passes, cur = [], 0, 0
        while passes < MAX_PASSES:
            cur = passes % 2
            with gpu.stage("peel"):
                self._clear(self.clear_fbos[f"depth{cur}"], -FAR, -FAR, 0.0, 0.0)
                if through or passes == 0:  # front[1] is cleared by the min-max stage
                    self._clear(self.clear_fbos[f"front{cur}"], 0.0, 0.0, 0.0, 0.0)
                else:  # start from the previous accumulation: fragments peeled earlier need not write
                    ctx.copy_framebuffer(self.clear_fbos[f"front{cur}"], self.clear_fbos[f"front{1 - cur}"])
                self._clear(self.clear_fbos["back_layer"], 0.0, 0.0, 0.0, 0.0)
                fbo = self.peel_fbo[cur]
                fbo.use()
                fbo.viewport = (0, 0, w, h)
                ctx.enable(ctx.BLEND)
                ctx.blend_equation = ctx.MAX
                (self.depth_init if passes == 0 else self.depth[1 - cur]).use(0)
                self.front[1 - cur].use(1)
                peel["init"].value = 0
                geo_vao.render()
            passes += 1
            with gpu.stage("blend"):
                self.back_fbo.use()
                self.back_fbo.viewport = (0, 0, w, h)
                ctx.blend_equation = ctx.FUNC_ADD
                ctx.blend_func = (ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA)
                self.back_layer.use(2)
                with self.query:
                    full.render(vertices=3)
            n = int(self.query.samples)
            samples.append(n)
            if n == 0:
                break
        with gpu.stage("final"):
            ctx.disable(ctx.BLEND)
            self.final_fbo.use()
            self.final_fbo.viewport = (0, 0, w, h)
            self.front[cur].use(3)
            self.back.use(4)
            self.depth_init.use(5)
            full_final.render(vertices=3)
        ctx.blend_func = ctx.DEFAULT_BLENDING
        for v in (geo_vao, full, full_final):
            v.release()
        done = samples[-1] == 0

        def counters():
            return {"peel_passes": passes, "geometry_passes": passes + 1, "samples_per_pass": samples,
                    **complexity_counters(self._fragment_counts(clip, w, h)), "all_layers_peeled": done}

        def invariants(c):
            return [] if done else [f"dual depth peeling stopped at the safety cap of {MAX_PASSES} passes"]

        return self.result(counters, invariants)

    def _fragment_counts(self, clip, w, h) -> np.ndarray:
        """Fragments per pixel (an untimed raster with additive blending; for the counters)."""
        ctx = self.gpu.ctx
        prog = self.gpu.program(self.shader("count.glsl"))
        prog["clip"].write(np.ascontiguousarray(clip.T, np.float32).tobytes())
        tex = ctx.texture((w, h), 1, dtype="f4")
        fbo = ctx.framebuffer([tex])
        vao = self.geo.vao(prog)
        try:
            fbo.use()
            fbo.clear(0.0)
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
            with self.gpu.blending((ctx.ONE, ctx.ONE)):
                vao.render()
            return read_texture(tex, 1)[..., 0]
        finally:
            vao.release()
            fbo.release()
            tex.release()
