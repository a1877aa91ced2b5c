"""``gtao``: ground-truth based ambient occlusion (Jimenez, Wu, Pesce, Jarabo, *Practical Real-Time
Strategies for Accurate Indirect Occlusion*, SIGGRAPH 2016 course), the screen-space AO engines ship
today; Intel's XeGTAO is its best-known implementation and the source of the defaults below.

Stages (all GPU; the screen-space passes are compute shaders):

``gbuffer``  the shared :class:`~ldbench.methods.gbuffer.GBuffer` (world position, camera-facing geometric normal).
``prefilter`` (``prefilter = "mip"`` only) ``prefilter.glsl``: XeGTAO's depth pre-filter, the view-space
             depth of every pixel and four coarser MIP levels (XeGTAO's weighted average) in one dispatch.
``gtao``     ``gtao.glsl``: per pixel, ``slices`` view-space slices (rotated per pixel by a spatial R2
             sequence along a 64×64 Hilbert curve, XeGTAO's noise without its temporal part), a horizon
             search of ``steps`` samples on each side (out to the projected radius, clamped to the image
             border on that side), and the slice's cosine-weighted visibility between the two horizons
             solved analytically with the projected normal. A sample reads the G-buffer
             (``prefilter = "none"``) or the depth MIP level its distance selects (``"mip"``).
``denoise``  ``denoise_passes`` × ``denoise.glsl``: a 3×3 edge-aware average (XeGTAO's spatial denoise).

The ``ao`` effect maps onto it as onto ``hbao``: the search radius is d_max projected at the pixel's
depth (clamped to ``max_radius_px``; that clamp is the radius when d_max = ∞), a sample at 3D distance
r ≥ d_max never raises a horizon, and a sample within d_max raises it with the weight ρ(r) of the effect's
fall-off (1 for ``step``, 1 − r²/d_max² for ``quadratic``) times GTAO's own fade over the last
``falloff_range`` of d_max: the horizon cosine moves from the tangent plane's towards the sample's by
that weight. docs/reference/methods/gtao.md has the derivation and the measured accuracy.

Parameters: ``ldbench methods gtao`` (docs/reference/parameters.md); the presets ``low``, ``medium``, ``high``
(the defaults) and ``ultra`` are XeGTAO's quality levels (:data:`QUALITY`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, Preset, param
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import gbuffer_param, mat_bytes
from ldbench.methods.uniforms import set_uniforms

FALLOFF_MODE = {"step": 0, "quadratic": 1}
DENOISE_SHARPNESS = 40.0  # inverse relative tolerance of the plane-distance term (as hbao's blur)
PREFILTERS = ("none", "mip")
DEPTH_PRECISIONS = ("32", "16")
MIP_LEVELS = 5  # XeGTAO's XE_GTAO_DEPTH_MIP_LEVELS: levels 0..4
MIP_BLOCK = 2 ** MIP_LEVELS // 2  # pixels per side of one pre-filter workgroup (16: level 4 is 1 texel of it)
MIP_RADIUS_SCALE = 0.75  # XeGTAO's depthRangeScaleFactor: the MIP filter's radius is 0.75 d_max
#: XeGTAO's quality levels (its vaGTAO.hlsl): slices, steps per side
QUALITY = {"low": (1, 2), "medium": (2, 2), "high": (3, 3), "ultra": (9, 3)}


@dataclass(frozen=True)
class GTAOParams(ParamsBase):
    slices: int = param(3, "slices per pixel (XeGTAO High: 3, Ultra: 9; a preset sets it)", lo=1, hi=64, paper=3)
    steps: int = param(3, "horizon samples per side of a slice (a preset sets it)", lo=1, hi=128, paper=3)
    distribution: float = param(2.0, "sample spacing power, denser near the pixel (XeGTAO's "
                                "SampleDistributionPower)", lo=0.25, hi=8.0, paper=2.0)
    falloff_range: float = param(0.0, "fraction of d_max over which the horizon weight fades to 0 (0 = none: "
                                 "the ao effect's fall-off alone; XeGTAO 0.615)", lo=0.0, hi=1.0, paper=0.615)
    thin_occluder: float = param(0.0, "view-z stretch of the fall-off distance, a thin-occluder heuristic (XeGTAO's "
                                 "ThinOccluderCompensation)",
                                 lo=0.0, hi=10.0, paper=0.0)
    final_power: float = param(1.0, "exponent on the visibility (XeGTAO ships 2.2 for contrast; 1 = the estimator)",
                               lo=0.1, hi=8.0)
    max_radius_px: float = param(256.0, "clamp of the projected radius in pixels (radius when d_max = inf)",
                                 lo=1.0, hi=4096.0)
    prefilter: str = param("none", "none = samples read the G-buffer; mip = XeGTAO's view-space depth MIP pre-filter "
                           "(far samples read coarser levels)", choices=PREFILTERS)
    depth_precision: str = param("32", "bits of the depth MIP levels 1..4 (prefilter = mip; level 0 stays 32)",
                                 choices=DEPTH_PRECISIONS)
    mip_offset: float = param(3.3, "log2 of the sample distance in px below which MIP level 0 is read "
                              "(prefilter = mip; XeGTAO's DepthMIPSamplingOffset)", lo=0.0, hi=16.0, paper=3.3)
    denoise_passes: int = param(1, "3x3 edge-aware denoise passes (XeGTAO's spatial denoise)", lo=0, hi=8, paper=1)
    denoise_beta: float = param(1.2, "weight of the centre pixel in the denoise (XeGTAO's DenoiseBlurBeta)", lo=0.0,
                                 hi=100.0, paper=1.2)
    seed: int = param(0, "offset of the R2 noise sequence", lo=0, hi=2**31 - 1)
    gbuffer: str = gbuffer_param()

    presets = {name: Preset(f"XeGTAO's {name.capitalize()} quality: {n} slice{'s' * (n > 1)}, {k} steps per side",
                            {"slices": n, "steps": k}) for name, (n, k) in QUALITY.items()}

    def __post_init__(self):
        super().__post_init__()
        if self.depth_precision != "32" and self.prefilter != "mip":
            raise LdbenchError(f"parameter depth_precision={self.depth_precision!r} needs prefilter = 'mip' "
                               f"(got prefilter = {self.prefilter!r}; without it samples read the G-buffer)")


_set = set_uniforms  # the shared helper (ldbench/methods/uniforms.py)


class GTAO(Method):
    name = "gtao"
    paper = "jimenez2016"
    effects = frozenset({"ao"})
    Params = GTAOParams

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene, gbuffer=self.params.gbuffer)
        mip, d16 = p.prefilter == "mip", p.depth_precision == "16"
        self.prog = gpu.compute(self.shader("gtao.glsl"), {"PREFILTER": mip, "DEPTH16": d16})
        self.prefilter_prog = gpu.compute(self.shader("prefilter.glsl"), {"DEPTH16": d16}) if mip else None
        self.denoise_prog = gpu.compute(self.shader("denoise.glsl"))
        _set(self.prog, slices=p.slices, steps=p.steps, distribution=p.distribution,
             falloff_range=p.falloff_range, thin_occluder=p.thin_occluder, final_power=p.final_power,
             max_radius_px=p.max_radius_px, noise_offset=(self.seed_for(p.seed, bits=31) * 288) % 2**32,
             mip_offset=p.mip_offset)
        self._size = None

    def _allocate(self, w, h):
        names = ["ao"] + (["ao.denoise_tmp"] if self.params.denoise_passes else [])
        self.tex = [self.res.texture(n, (w, h), 1, "f4") for n in names]
        for t in self.tex:
            t.filter = (self.gpu.ctx.NEAREST, self.gpu.ctx.NEAREST)
        if self.params.prefilter == "mip":
            self._allocate_mips(w, h)
        self._size = (w, h)

    def _allocate_mips(self, w, h):
        """The view-space depth MIP chain, padded to a multiple of :data:`MIP_BLOCK` pixels so that every
        level is exactly half the one before: levels 0..4 of one 32-bit texture, or (``depth_precision =
        "16"``) level 0 alone in 32 bits and levels 1..4 as a 16-bit texture of half the size."""
        ctx = self.gpu.ctx
        w16, h16 = -(-w // MIP_BLOCK) * MIP_BLOCK, -(-h // MIP_BLOCK) * MIP_BLOCK
        chains = [("depth_mips", (w16, h16), "f4", MIP_LEVELS)]
        if self.params.depth_precision == "16":
            chains = [("depth_mips", (w16, h16), "f4", 1), ("depth_mips16", (w16 // 2, h16 // 2), "f2", MIP_LEVELS - 1)]
        self.mips = []
        for name, (tw, th), dtype, levels in chains:
            tex = ctx.texture((tw, th), 1, dtype=dtype)
            if levels > 1:
                tex.build_mipmaps(0, levels - 1)  # allocates the levels (their contents are written per frame)
            tex.filter = (ctx.NEAREST_MIPMAP_NEAREST if levels > 1 else ctx.NEAREST, ctx.NEAREST)
            nbytes = sum((tw >> i) * (th >> i) for i in range(levels)) * int(dtype[-1])
            self.mips.append(self.res.adopt(name, tex, nbytes))
        # image bindings of levels 0..4 for the pre-filter: (texture, level)
        self.mip_levels = [(self.mips[0], 0)] + [(self.mips[-1], i - len(self.mips) + 1) for i in range(1, MIP_LEVELS)]

    def run_prefilter(self, view, effect):
        """Dispatch the depth pre-filter for ``view`` (the G-buffer already rendered)."""
        pr = self.prefilter_prog
        pr["view"].write(mat_bytes(view.camera.view_matrix()))
        radius = 0.0 if math.isinf(effect.d_max) else MIP_RADIUS_SCALE * float(effect.d_max)
        _set(pr, filter_radius=radius, g_position=0)
        self.gbuf.bind(0)
        for i, (tex, level) in enumerate(self.mip_levels):
            tex.bind_to_image(getattr(B, f"GTAO_DEPTH{i}"), read=False, write=True, level=level)
        w16, h16 = self.mips[0].size
        pr.run(w16 // MIP_BLOCK, h16 // MIP_BLOCK)
        self.gpu.ctx.memory_barrier()

    def read_mips(self) -> list:
        """The depth MIP levels 0..4 as float32 (H_i, W_i) arrays, row 0 = top (tests and analysis)."""
        out = []
        for tex, level in self.mip_levels:
            w, h = max(1, tex.width >> level), max(1, tex.height >> level)
            dt = np.float16 if tex.dtype == "f2" else np.float32
            a = np.frombuffer(tex.read(level=level), dt).reshape(h, w).astype(np.float32)
            out.append(a[::-1].copy())
        return out

    def frame(self, view, effect, inputs=None):
        if effect.name != "ao":
            raise LdbenchError(f"method 'gtao' does not support effect {effect.name!r}")
        p, w, h = self.params, view.width, view.height
        if self._size != (w, h):
            self._allocate(w, h)
        groups = ((w + 7) // 8, (h + 7) // 8)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        if p.prefilter == "mip":
            with self.gpu.stage("prefilter"):
                self.run_prefilter(view, effect)
        with self.gpu.stage("gtao"):
            pr = self.prog
            pr["view"].write(mat_bytes(view.camera.view_matrix()))
            unbounded = math.isinf(effect.d_max)
            _set(pr, focal_px=0.5 * h / math.tan(math.radians(view.camera.fov_y) / 2), half_size=(0.5 * w, 0.5 * h),
                 falloff_mode=2 if unbounded else FALLOFF_MODE[effect.falloff],
                 d_max=1.0 if unbounded else float(effect.d_max), g_position=0, g_normal=1, depth_mips=3,
                 depth_mips16=4)
            self.gbuf.bind(0)
            if p.prefilter == "mip":
                for unit, tex in enumerate(self.mips, start=3):  # after the G-buffer's 0..2
                    tex.use(unit)
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
