"""``depth-peeling``: front-to-back depth peeling (Everitt 2001; Bavoil & Myers 2008), the OIT baseline of
yang2010 Table 1; effect ``oit``.

Per frame, one geometry pass per layer until an occlusion query says none is left (stages repeat and add up):

``peel``       ``peel.glsl``: the whole scene (both faces) with the depth test LESS into a layer texture
               (albedo, opacity) and a depth buffer; fragments at or in front of the previous pass's layer are
               discarded (its depth buffer, read as a texture; the two depth buffers ping-pong). A
               ``samples_passed`` occlusion query counts the fragments that reached the layer; when it reads
               zero, every layer has been peeled and the loop ends (the query is read back after each pass:
               the CPU waits for the GPU, as depth peeling must).
``composite``  ``composite.glsl``: a full-screen pass blends the layer under the accumulation (C += T α c,
               T *= 1 − α, fixed-function blending) and counts it per pixel.
``final``      C + T · background into the output.

Depth is the linear view depth quantized to 2^20 steps of [near, far] in the 24-bit depth buffer (see
``peel.glsl``): surfaces closer than one step at a pixel — in particular coincident ones, the effect's
ties — are a single layer to depth peeling, which keeps the first fragment to arrive and loses the others.

``max_layers = n`` stops after n layers (a first-n variant of peeling: the rest is dropped, as in
``ll-oit``'s). Counters: ``peel_passes`` (geometry passes, the last one empty unless capped), ``layers``,
``depth_complexity_max`` / ``depth_complexity_mean`` (layers per pixel, mean over covered pixels),
``fragments`` (layers summed over pixels), ``pixels_covered``, ``samples_per_pass`` (the queries).
Invariant: peeling ended because no fragment was left (not at the safety cap :data:`MAX_PASSES`).

Parameters: ``ldbench methods depth-peeling`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.oit import PeelingMethod, complexity_counters

MAX_PASSES = 4096  # safety cap: a scene deeper than this is reported (invariant), never an endless loop


@dataclass(frozen=True)
class DepthPeelingParams(ParamsBase):
    max_layers: int = param(0, "peel at most n layers (0 = until the occlusion query reads zero)", lo=0,
                            hi=MAX_PASSES)


class DepthPeeling(PeelingMethod):
    """Front-to-back depth peeling with an occlusion query per pass."""

    name = "depth-peeling"
    paper = "yang2010"
    Params = DepthPeelingParams

    def resize(self, w, h):
        r, ctx = self.res, self.gpu.ctx
        self.depth = [r.depth_texture(f"oit.dp.depth{i}", (w, h)) for i in range(2)]
        for d in self.depth:
            d.compare_func = ""  # read as plain depth values (moderngl enables shadow comparison by default)
        self.layer = r.texture("oit.dp.layer", (w, h), 4, "f4")
        self.accum = r.texture("oit.dp.accum", (w, h), 4, "f4")
        self.count = r.texture("oit.dp.count", (w, h), 1, "f4")
        self.peel_fbo = [ctx.framebuffer([self.layer], d) for d in self.depth]
        self.comp_fbo = ctx.framebuffer([self.accum, self.count])
        self.final_fbo = ctx.framebuffer([self.out])
        self.own(*self.peel_fbo, self.comp_fbo, self.final_fbo)

    def frame(self, view, effect, inputs=None):
        self.check_effect(effect)
        gpu, ctx, p = self.gpu, self.gpu.ctx, self.params
        w, h = view.width, view.height
        self.output(w, h)
        peel, _, near, far = self.camera_program(view, "peel.glsl")
        comp = gpu.program(self.shader("composite.glsl"))
        final = gpu.program(self.shader("composite.glsl"), {"OIT_FINAL": 1})
        peel["depth_map"].value = (float(near), float(1.0 / (far - near)))
        peel["prev_depth"].value = 0
        comp["layer"].value = 1
        geo_vao = self.geo.vao(peel)
        full = ctx.vertex_array(comp, [])
        full_final = ctx.vertex_array(final, [])
        ctx.disable(ctx.CULL_FACE)
        samples, layers, passes = [], 0, 0
        with gpu.stage("peel"):  # start: empty accumulation (T = 1) and no layers counted
            self.comp_fbo.use()
            self.comp_fbo.viewport = (0, 0, w, h)
            self.comp_fbo.clear(0.0, 0.0, 0.0, 1.0)
        while passes < MAX_PASSES:
            cur = passes % 2
            with gpu.stage("peel"):
                fbo = self.peel_fbo[cur]
                fbo.use()
                fbo.viewport = (0, 0, w, h)
                fbo.clear(0.0, 0.0, 0.0, -1.0, depth=1.0)
                ctx.disable(ctx.BLEND)
                ctx.enable(ctx.DEPTH_TEST)
                ctx.depth_func = "<"
                self.depth[1 - cur].use(0)
                peel["first"].value = int(passes == 0)
                self.set_common_uniforms(peel, view)
                with self.query:
                    geo_vao.render()
            passes += 1
            n = int(self.query.samples)
            samples.append(n)
            if n == 0:
                break
            layers += 1
            with gpu.stage("composite"):
                self.comp_fbo.use()
                ctx.disable(ctx.DEPTH_TEST)
                ctx.enable(ctx.BLEND)
                ctx.blend_equation = ctx.FUNC_ADD
                ctx.blend_func = (ctx.DST_ALPHA, ctx.ONE, ctx.ZERO, ctx.ONE_MINUS_SRC_ALPHA)
                self.layer.use(1)
                full.render(vertices=3)
            if p.max_layers and layers >= p.max_layers:
                break
        with gpu.stage("final"):
            ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
            self.final_fbo.use()
            self.final_fbo.viewport = (0, 0, w, h)
            self.accum.use(2)
            self.count.use(3)
            final["accum"].value, final["count"].value = 2, 3
            self.set_common_uniforms(final, view)
            full_final.render(vertices=3)
        ctx.blend_func = ctx.DEFAULT_BLENDING
        for v in (geo_vao, full, full_final):
            v.release()
        done = samples[-1] == 0
        count = self.count

        def counters():
            return {"peel_passes": passes, "layers": layers, **complexity_counters(read_texture(count, 1)[..., 0]),
                    "samples_per_pass": samples, "all_layers_peeled": done, "max_layers": p.max_layers}

        def invariants(c):
            if not done and not (p.max_layers and layers >= p.max_layers):
                return [f"depth peeling stopped at the safety cap of {MAX_PASSES} passes with fragments left"]
            return []

        return self.result(counters, invariants)
