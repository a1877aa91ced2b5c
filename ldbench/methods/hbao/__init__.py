"""``hbao``: image-space horizon-based ambient occlusion (Bavoil, Sainz, Dimitrov, SIGGRAPH 2008 talk).

The screen-space baseline that Aalund et al. 2015 (§5.1) compare their LDM ambient occlusion with.
All it knows about the scene is the G-buffer of the current view (one depth layer). docs/reference/methods/hbao.md has
the derivations, the measured accuracy and the known limits.

Stages (all GPU; the screen-space passes are compute shaders):

``gbuffer``  the shared :class:`~ldbench.methods.gbuffer.GBuffer` (world position, camera-facing geometric normal).
``hbao``     ``hbao.glsl``: per pixel, ``directions`` screen-space directions rotated by a 4×4 tiled random
             texture (deterministic from ``seed``), each marched in ``steps`` equal pixel steps with a
             jittered start out to the projected radius of d_max (``d_max · focal / depth`` pixels,
             clamped to ``max_radius_px`` and to the image border in that direction); the horizon is the
             highest sample S whose 3D distance r = |S − P| is below d_max; then one of two integrals.
``deinterleave`` (``access = "deinterleaved"`` only) ``deinterleave.glsl``: the view-space normals and
             depths into 4×4 quarter-resolution layers, one per cell of the noise tile (16 bytes a texel).
``blur``     (``blur = true``) ``blur.glsl``: separable cross-bilateral blur (Gaussian in pixels × a
             tangent-plane distance term) that removes the 4×4 noise pattern without crossing depth edges.

Access (``access``)
-------------------
``interleaved`` — one invocation per pixel in image order: the 8×8 pixels of a workgroup hold all 16
    rotations of the noise tile, so at each step their reads scatter over a circle of the sample radius
    (up to ``max_radius_px``) on the full-resolution G-buffer; once that G-buffer no longer fits the GPU's
    cache (3840 × 2160: 265 MB of position and normal) nearly every read misses.
``deinterleaved`` — the same image, cache-friendly: a pre-pass copies the view-space
    normals and depths into 4×4 layers, layer (p mod 4) holding pixel p at p / 4 (HBAO+'s deinterleaved
    texturing), and the AO pass runs each workgroup on one layer, so its pixels share one rotation and jitter
    and a sample offset reads neighbouring texels of one layer. Unlike HBAO+, samples are not snapped to
    the layer: a sample at pixel q reads layer (q mod 4) (the same for the whole workgroup where the offset
    is), so the samples and the arithmetic are those of ``interleaved``.

Integrals (``integral``)
------------------------
``hbao`` — the 2008 formula: elevation angles are measured from the image plane (view-space z is the
    zenith); t = elevation of the surface tangent whose projection points along the marching direction
    (what the 2008 implementation gets from the depth derivatives), h = horizon elevation;
    ``AO = 1 − 1/N_d Σ_dirs Σ_k W(r_k)(sin h_k − sin h_{k−1})`` with h_0 = t + angle_bias, i.e. the
    per-sample attenuation of NVIDIA's implementation (each sample that raises the horizon adds its
    increment of sin h weighted by W at its own distance). W(r) is the effect's obscurance ρ(r):
    1 − r²/d_max² for ``quadratic`` (the 2008 falloff), 1 within d_max for ``step``. Not the ``ao``
    effect's integral: sin h − sin t is the *uniform* solid-angle measure of a hemisphere about the
    view direction cut by the tangent plane, not the cosine-weighted measure about the normal.
``cosine`` — the ``ao`` effect's definition A = 1/π ∫ V cos θ dω. The plane through the eye, P and a
    screen direction contains every pixel of that screen line, so a marched direction explores exactly
    one slice of the hemisphere. Angle θ from the view vector v = −P/|P| towards the marching
    direction; normal projected into the slice: length |n_p|, angle γ. The cosine-weighted measure of
    the slice between v and θ is ``F(θ) = ¼(−cos(2θ − γ) + cos γ + 2θ sin γ)`` (dF/dθ = sin θ cos(θ − γ);
    Jimenez et al. 2016, GTAO), and ``A = 1/π ∫₀^{2π} |n_p| F(h(φ)) dφ`` exactly, h(φ) the horizon of
    the half-slice φ (at most the tangent plane γ + π/2). Estimated with the N_d marched half-slices as
    the ratio ``Σ |n_p| F_vis / Σ |n_p| F(γ + π/2)`` (the denominator's mean over directions is exactly
    ½; the ratio makes unoccluded pixels exactly 1 for any N_d). Falloff with V = 1 − ρ(t): marching outwards,
    a sample that raises the horizon from θ_{k−1} to θ_k occludes the band between them with weight
    ρ(r_k), so ``F_vis = F(γ + π/2) − Σ_k ρ(r_k)(F(θ_{k−1}) − F(θ_k))``; for step falloff (or
    d_max = ∞) this telescopes to F(horizon): GTAO's estimator. What still differs from the Mitsuba
    reference is screen-space information loss (one layer, surfaces assumed infinitely thick, nothing
    off screen) and the horizon's sampling (``steps``).

Sample reconstruction (``plane_fit``, both integrals): a sample pixel's surface point lies on the ray
through the pixel *centre*, up to 0.7 px off the marching line and hence off the slice; on sloped
surfaces that reads as false occlusion (the reason the 2008 method needs an angle bias). With
``plane_fit`` the point is moved along its own tangent plane to the view ray through the exact sample
position (skipped at grazing angles or when that moves it by more than 5 % of its depth).

``angle_bias``: a sample must rise above the tangent plane by more than the bias to occlude, and the
bias band is never counted (the horizon starts at tangent + bias; unoccluded stays 1). Negative = the
integral's default: 10° for ``hbao`` (a moderate value; the bias hides tessellation self-occlusion and
is a tunable of NVIDIA's sample, whose ports use up to 30°), 0° for ``cosine`` (the G-buffer holds exact
float32 positions and geometric normals, so flat surfaces do not self-occlude and any bias is a bias).

d_max = ∞ (classic AO): every sample counts and the screen radius is ``max_radius_px`` (and the image
border); occluders farther away on screen, behind the first layer or off screen are missed, which is
the screen-space limitation §5.1 of Aalund et al. shows for large d_max. The radius is d_max projected
at P's depth; occluders much closer to the camera than P may be within d_max yet outside it.

Parameters: ``ldbench methods hbao`` (docs/reference/parameters.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Method, Result
from ldbench.methods.gbuffer import gbuffer_param, mat_bytes
from ldbench.methods.uniforms import set_uniforms

INTEGRALS = ("hbao", "cosine")
SAMPLINGS = ("fixed", "pixel_step")
ACCESSES = ("interleaved", "deinterleaved")
DEFAULT_BIAS_DEG = {"hbao": 10.0, "cosine": 0.0}
FALLOFF_MODE = {"step": 0, "quadratic": 1}
NOISE_TILE = 4
LAYER_TEXEL_BYTES = 16  # layers.glsl: view-space normal and depth, one vec4


@dataclass(frozen=True)
class HBAOParams(ParamsBase):
    directions: int = param(8, "screen-space directions per pixel (N_d)", lo=1, hi=64, paper=8)
    steps: int = param(8, "samples per direction (N_s; with sampling = pixel_step their cap)", lo=1, hi=4096,
                       paper=8)
    sampling: str = param("fixed", "fixed: min(steps, radius in pixels) samples per direction whatever d_max; "
                          "pixel_step: one every step_px pixels out to the projected radius (NVIDIA's HBAO sample), "
                          "so the cost grows with d_max", choices=SAMPLINGS)
    step_px: float = param(4.0, "pixels between samples with sampling = pixel_step", lo=0.5, hi=256.0)
    angle_bias: float = param(-1.0, "angle bias in degrees (< 0: 10 for hbao, 0 for cosine)", lo=-1.0, hi=60.0)
    max_radius_px: float = param(256.0, "clamp of the projected radius in pixels (radius when d_max = inf)",
                                 lo=1.0, hi=4096.0)
    integral: str = param("hbao", "hbao = 2008 formula; cosine = the ao effect's cosine-weighted integral",
                          choices=INTEGRALS)
    plane_fit: bool = param(True, "reconstruct each sample on its pixel's tangent plane at the exact sample "
                                 "point")
    blur: bool = param(True, "depth-aware separable blur after the AO pass")
    blur_radius: int = param(2, "blur half-width in pixels (Gaussian sigma = (radius + 1) / 2)", lo=0, hi=32)
    blur_sharpness: float = param(40.0, "inverse relative tolerance of the blur's tangent-plane distance term",
                                  lo=0.0, hi=1e4)
    seed: int = param(0, "seed of the 4x4 rotation/jitter texture", lo=0)
    access: str = param("deinterleaved", "deinterleaved = 4x4 quarter-resolution layers, one rotation per workgroup "
                        "(cache-friendly: 2.7x faster at 3840x2160 on an H100, the same image); interleaved = "
                        "pixels in image order", choices=ACCESSES)
    gbuffer: str = gbuffer_param()

    def bias_degrees(self) -> float:
        return DEFAULT_BIAS_DEG[self.integral] if self.angle_bias < 0 else self.angle_bias


def noise_tile(seed: int, tile: int = NOISE_TILE) -> np.ndarray:
    """tile×tile×2 float32: (rotation, jitter) in [0, 1), each a stratified permutation of the tile's
    tile² strata (so a tile-sized blur averages all rotations), shuffled by ``seed``."""
    rng = np.random.default_rng(seed)
    n = tile * tile
    rot = (rng.permutation(n) + rng.random(n)) / n
    jit = (rng.permutation(n) + rng.random(n)) / n
    return np.stack([rot, jit], -1).reshape(tile, tile, 2).astype(np.float32)


_set = set_uniforms  # the shared helper (ldbench/methods/uniforms.py)


class HBAO(Method):
    name = "hbao"
    paper = "bavoil2008"
    effects = frozenset({"ao"})
    Params = HBAOParams

    def setup(self, gpu, scene):
        p = self.params
        self.setup_scene(gpu, scene, gbuffer=p.gbuffer)
        self.deinterleaved = p.access == "deinterleaved"
        defines = {"INTEGRAL": INTEGRALS.index(p.integral), "PLANE_FIT": p.plane_fit,
                   "DEINTERLEAVED": self.deinterleaved}
        self.prog = gpu.compute(self.shader("hbao.glsl"), defines)
        self.deinterleave_prog = gpu.compute(self.shader("deinterleave.glsl")) if self.deinterleaved else None
        self.debug_progs: dict = {}  # compiled by sample_counts() and workgroups()
        self._defines = defines
        self.blur_prog = gpu.compute(self.shader("blur.glsl"))
        self.noise = self.res.texture("noise", (NOISE_TILE, NOISE_TILE), 2, "f4",
                                      noise_tile(self.seed_for(p.seed)).tobytes())
        self.noise.filter = (gpu.ctx.NEAREST, gpu.ctx.NEAREST)
        self.noise.repeat_x = self.noise.repeat_y = True
        self._set_constants(self.prog)
        self._size = None

    def _set_constants(self, prog):
        p = self.params
        bias = math.radians(p.bias_degrees())
        _set(prog, directions=p.directions, steps=p.steps, angle_bias=bias, cos_bias=math.cos(bias),
             sin_bias=math.sin(bias), max_radius_px=p.max_radius_px, sampling=SAMPLINGS.index(p.sampling),
             step_px=p.step_px)

    def _allocate(self, w, h):
        self.ao = self.res.texture("ao", (w, h), 1, "f4")
        textures = [self.ao]
        if self.params.blur:
            self.ao_tmp = self.res.texture("ao.blur_tmp", (w, h), 1, "f4")
            textures.append(self.ao_tmp)
        if self.deinterleaved:
            # one layer per noise-tile cell, each a multiple of the 8 × 8 workgroup: no group spans two
            self.quarter = tuple(-(-n // (NOISE_TILE * 8)) * 8 for n in (w, h))
            texels = NOISE_TILE * NOISE_TILE * self.quarter[0] * self.quarter[1]
            self.layers = self.res.buffer("layers", reserve=texels * LAYER_TEXEL_BYTES)
        for t in textures:
            t.filter = (self.gpu.ctx.NEAREST, self.gpu.ctx.NEAREST)
        self._size = (w, h)

    def _deinterleave(self, view):
        pr = self.deinterleave_prog
        pr["view"].write(mat_bytes(view.camera.view_matrix()))
        _set(pr, quarter=self.quarter, g_position=0, g_normal=1)
        self.gbuf.bind(0)
        self.layers.bind_to_storage_buffer(B.HBAO_LAYERS)
        pr.run((view.width + 7) // 8, (view.height + 7) // 8)
        self.gpu.ctx.memory_barrier()

    def frame(self, view, effect, inputs=None):
        if effect.name != "ao":
            raise LdbenchError(f"method 'hbao' does not support effect {effect.name!r}")
        p, w, h = self.params, view.width, view.height
        if self._size != (w, h):
            self._allocate(w, h)
        groups = ((w + 7) // 8, (h + 7) // 8)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        if self.deinterleaved:
            with self.gpu.stage("deinterleave"):
                self._deinterleave(view)
        with self.gpu.stage("hbao"):
            self._dispatch(self.prog, view, effect)
        if p.blur:
            with self.gpu.stage("blur"):
                b = self.blur_prog
                _set(b, radius=p.blur_radius, sharpness=p.blur_sharpness, eye=tuple(view.camera.origin),
                     g_position=0, g_normal=1, in_ao=4)
                for axis, src, dst in (((1, 0), self.ao, self.ao_tmp), ((0, 1), self.ao_tmp, self.ao)):
                    self.gpu.ctx.memory_barrier()
                    src.use(4)
                    dst.bind_to_image(B.OUT_IMAGE, read=False, write=True)
                    b["axis"].value = axis
                    b.run(*groups)
        self.gpu.ctx.memory_barrier()
        out = self.ao
        counters = {"directions": p.directions, "steps": p.steps, "samples_per_pixel": p.directions * p.steps}
        if p.sampling == "pixel_step":  # steps is a cap; the count follows the projected radius
            counters = {"directions": p.directions, "max_steps": p.steps, "step_px": p.step_px}
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters=counters)

    def _dispatch(self, pr, view, effect):
        w, h = view.width, view.height
        if "view" in pr:  # not with deinterleaved access: the layers hold view-space values
            pr["view"].write(mat_bytes(view.camera.view_matrix()))
        unbounded = math.isinf(effect.d_max)
        _set(pr, focal_px=0.5 * h / math.tan(math.radians(view.camera.fov_y) / 2), half_size=(0.5 * w, 0.5 * h),
             falloff_mode=2 if unbounded else FALLOFF_MODE[effect.falloff],
             d_max=1.0 if unbounded else float(effect.d_max), g_position=0, g_normal=1, noise=3)
        self.gbuf.bind(0)
        self.noise.use(3)
        groups = ((w + 7) // 8, (h + 7) // 8)
        if self.deinterleaved:
            _set(pr, quarter=self.quarter)
            self.layers.bind_to_storage_buffer(B.HBAO_LAYERS)
            groups = (NOISE_TILE * self.quarter[0] // 8, NOISE_TILE * self.quarter[1] // 8)
        self.ao.bind_to_image(B.OUT_IMAGE, read=False, write=True)
        pr.run(*groups)

    def sample_counts(self, view, effect) -> np.ndarray:
        """(H, W) float32: the samples the AO pass marches per pixel (summed over directions), from the
        kernel compiled with COUNT_STEPS; what ``sampling`` changes, for tests and analysis."""
        return self._debug_pass(view, effect, "COUNT_STEPS")

    def workgroups(self, view, effect) -> np.ndarray:
        """(H, W) float32: the index of the workgroup that computes each pixel in the AO pass, from the kernel
        compiled with GROUP_IDS; what ``access`` changes, for tests and analysis."""
        return self._debug_pass(view, effect, "GROUP_IDS")

    def _debug_pass(self, view, effect, define: str) -> np.ndarray:
        """The AO pass compiled with ``define`` = 1, run on ``view``: its output image."""
        w, h = view.width, view.height
        if self._size != (w, h):
            self._allocate(w, h)
        if define not in self.debug_progs:
            self.debug_progs[define] = self.gpu.compute(self.shader("hbao.glsl"), {**self._defines, define: 1})
            self._set_constants(self.debug_progs[define])
        self.gbuf.render(view)
        if self.deinterleaved:
            self._deinterleave(view)
        self._dispatch(self.debug_progs[define], view, effect)
        self.gpu.ctx.memory_barrier()
        return read_texture(self.ao, 1)[..., 0]

