"""``gtao``: ground-truth based ambient occlusion (Jimenez, Wu, Pesce, Jarabo, *Practical Real-Time
Strategies for Accurate Indirect Occlusion*, SIGGRAPH 2016 course), the screen-space AO engines ship
today; Intel's XeGTAO is its best-known implementation and the source of the defaults below.

Stages (all GPU; the screen-space passes are compute shaders):

``gbuffer``  the shared :class:`~ldbench.methods.gbuffer.GBuffer` (world position, camera-facing geometric normal).
``gtao``     ``gtao.glsl``: per pixel, ``slices`` view-space slices (rotated per pixel by a spatial R2
             sequence along a 64×64 Hilbert curve, XeGTAO's noise without its temporal part), a horizon
             search of ``steps`` samples on each side, and the slice's cosine-weighted visibility between
             the two horizons solved analytically with the projected normal.
``denoise``  ``denoise_passes`` × ``denoise.glsl``: a 3×3 edge-aware average (XeGTAO's spatial denoise).

The ``ao`` effect maps onto it as onto ``hbao``: the search radius is d_max projected at the pixel's
depth (clamped to ``max_radius_px``; that clamp is the radius when d_max = ∞), a sample at 3D distance
r ≥ d_max never raises a horizon, and a sample within d_max raises it with the weight ρ(r) of the effect's
fall-off (1 for ``step``, 1 − r²/d_max² for ``quadratic``) times GTAO's own fade over the last
``falloff_range`` of d_max: the horizon cosine moves from the tangent plane's towards the sample's by
that weight. docs/gtao.md has the derivation and the measured accuracy.

==================  =======  ==========================================================================
Parameter           Default  Meaning
==================  =======  ==========================================================================
``slices``          3        slices per pixel (XeGTAO "High"; "Ultra" 9)
``steps``           3        samples per side of a slice (XeGTAO "High" and "Ultra")
``distribution``    2        sample spacing power (XeGTAO's SampleDistributionPower)
``falloff_range``   0.615    fraction of d_max over which the horizon weight fades to 0 (XeGTAO); 0 = none
``thin_occluder``   0        view-z stretch of the fall-off distance (XeGTAO's ThinOccluderCompensation)
``final_power``     1        exponent on the visibility (XeGTAO ships 2.2 for contrast; 1 = the estimator)
``max_radius_px``   256      clamp of the projected radius in pixels (the radius when d_max = ∞)
``denoise_passes``  1        3×3 edge-aware denoise passes (XeGTAO "High": 1)
``denoise_beta``    1.2      weight of the centre pixel in the denoise (XeGTAO's DenoiseBlurBeta)
``seed``            0        offset of the R2 noise sequence
``gbuffer``         compute  the G-buffer's raster: ``compute`` or ``hardware`` (docs/gbuffer.md; the same textures)
==================  =======  ==========================================================================
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import gbuffer_param, mat_bytes
from ldbench.methods.uniforms import set_uniforms

FALLOFF_MODE = {"step": 0, "quadratic": 1}
DENOISE_SHARPNESS = 40.0  # inverse relative tolerance of the plane-distance term (as hbao's blur)


@dataclass(frozen=True)
class GTAOParams(ParamsBase):
    slices: int = param(3, "slices per pixel (XeGTAO High: 3, Ultra: 9)", lo=1, hi=64, paper=3)
    steps: int = param(3, "horizon samples per side of a slice", lo=1, hi=128, paper=3)
    distribution: float = param(2.0, "sample spacing power (denser near the pixel)", lo=0.25, hi=8.0, paper=2.0)
    falloff_range: float = param(0.615, "fraction of d_max over which the horizon weight fades to 0 (0 = none)",
                                 lo=0.0, hi=1.0, paper=0.615)
    thin_occluder: float = param(0.0, "view-z stretch of the fall-off distance (thin-occluder heuristic)",
                                 lo=0.0, hi=10.0, paper=0.0)
    final_power: float = param(1.0, "exponent on the visibility (XeGTAO ships 2.2; 1 = the estimator)",
                               lo=0.1, hi=8.0)
    max_radius_px: float = param(256.0, "clamp of the projected radius in pixels (radius when d_max = inf)",
                                 lo=1.0, hi=4096.0)
    denoise_passes: int = param(1, "3x3 edge-aware denoise passes", lo=0, hi=8, paper=1)
    denoise_beta: float = param(1.2, "weight of the centre pixel in the denoise", lo=0.0, hi=100.0, paper=1.2)
    seed: int = param(0, "offset of the R2 noise sequence", lo=0, hi=2**31 - 1)
    gbuffer: str = gbuffer_param()


_set = set_uniforms  # the shared helper (ldbench/methods/uniforms.py)


class GTAO(Method):
    name = "gtao"
    paper = "jimenez2016"
    effects = frozenset({"ao"})
    Params = GTAOParams

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene, gbuffer=self.params.gbuffer)
        self.prog = gpu.compute(self.shader("gtao.glsl"))
        self.denoise_prog = gpu.compute(self.shader("denoise.glsl"))
        _set(self.prog, slices=p.slices, steps=p.steps, distribution=p.distribution,
             falloff_range=p.falloff_range, thin_occluder=p.thin_occluder, final_power=p.final_power,
             max_radius_px=p.max_radius_px, noise_offset=(self.seed_for(p.seed, bits=31) * 288) % 2**32)
        self._size = None

    def _allocate(self, w, h):
        names = ["ao"] + (["ao.denoise_tmp"] if self.params.denoise_passes else [])
        self.tex = [self.res.texture(n, (w, h), 1, "f4") for n in names]
        for t in self.tex:
            t.filter = (self.gpu.ctx.NEAREST, self.gpu.ctx.NEAREST)
        self._size = (w, h)

    def frame(self, view, effect, inputs=None):
        if effect.name != "ao":
            raise LdbenchError(f"method 'gtao' does not support effect {effect.name!r}")
        p, w, h = self.params, view.width, view.height
        if self._size != (w, h):
            self._allocate(w, h)
        groups = ((w + 7) // 8, (h + 7) // 8)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        with self.gpu.stage("gtao"):
            pr = self.prog
            pr["view"].write(mat_bytes(view.camera.view_matrix()))
            unbounded = math.isinf(effect.d_max)
            _set(pr, focal_px=0.5 * h / math.tan(math.radians(view.camera.fov_y) / 2), half_size=(0.5 * w, 0.5 * h),
                 falloff_mode=2 if unbounded else FALLOFF_MODE[effect.falloff],
                 d_max=1.0 if unbounded else float(effect.d_max), g_position=0, g_normal=1)
            self.gbuf.bind(0)
            self.tex[0].bind_to_image(B.OUT_IMAGE, read=False, write=True)
            pr.run(*groups)
        out = self.tex[0]
        if p.denoise_passes:
            with self.gpu.stage("denoise"):
                b = self.denoise_prog
                _set(b, beta=p.denoise_beta, sharpness=DENOISE_SHARPNESS, eye=tuple(view.camera.origin),
                     g_position=0, g_normal=1, in_ao=4)
                for i in range(p.denoise_passes):
                    src, dst = self.tex[i % 2], self.tex[1 - i % 2]
                    self.gpu.ctx.memory_barrier()
                    src.use(4)
                    dst.bind_to_image(B.OUT_IMAGE, read=False, write=True)
                    b.run(*groups)
                    out = dst
        self.gpu.ctx.memory_barrier()
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters={"slices": p.slices, "steps": p.steps,
                                "samples_per_pixel": 2 * p.slices * p.steps})
