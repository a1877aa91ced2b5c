"""``vpl_range``: the range of each virtual point light (VPL) from six rays, checked VPL by VPL against the
exact distances along the same rays (archer2019 §3.2).

**Inputs** (:class:`VplBatch`, built by the harness, deterministic in (scene, ``rsm``, seed), handed
identically to the method and to the oracle):

1. **VPLs**: a reflective shadow map (RSM) of the scene's first light, built with **Mitsuba** on the
   harness side (:func:`make_vpls`, hits from ``exact.rsm_hits``): ``rsm`` × ``rsm`` rays from the light through the
   texel centres of :func:`rsm_camera` (a square perspective view along the spot axis with a field of view
   of twice the cut-off angle), exact first hits. Each texel whose ray hits inside the cone (fall-off > 0)
   is one VPL: position y, normal n (geometric, facing the light), flux Φ = albedo · I · fall-off · Ω
   (Ω = the texel's solid angle, :func:`texel_solid_angle`), the area its texel covers
   (Ω · d² / max(|cos|, 0.05)) and the light's direction at it (ω_i, light → y).
2. **Rays**, six per VPL (:func:`vpl_rays`): the primary direction p (``primary = "normal"``: n;
   ``"reflected"``: the mirror direction of ω_i about n) and five around it at ``cone_angle`` from p, at
   azimuths φ₀ + 2πk/5 in the frame of p (Duff et al. 2017); φ₀ = 2π · hash(texel, seed) (:func:`hash01`,
   the same integer hash in numpy and GLSL, so the method's own VPLs for ``indirect`` get the same rays).
   Origin (:func:`ldbench.core.conventions.spawn_origin`, as the ``rays`` effect): y' + ε n, ε = (1 + max|y'|) ·
   Mitsuba's ``RayEpsilon``, y' = y except within a few ε of its triangle's edges
   (:func:`ldbench.core.conventions.crease_point`). t_max = the miss range.
3. **Range** of a VPL (:func:`ldbench.core.conventions.reduce_range`): the ``range_mode`` (``mean`` or ``max``)
   of its six distances, each clamped to the **miss range** ``miss_range`` × scene diagonal, which is also
   the range of a ray that hits nothing.

**A method returns** ``arrays["range"]`` (N,) and ``arrays["t"]`` (6N,) (inf = miss; NaN = no answer,
counted wrong; a range of ±inf or a distance of -inf counts as no answer and in ``nonfinite``, and makes
the row ``degraded``).

**Oracle** (:mod:`ldbench.references.vpl_range`): ``trace_oracle`` of the ``rays`` effect on the same 6N rays
(Mitsuba ``ray_intersect_preliminary``), reduced the same way, timed the same way.

**Metrics**: per VPL, e = |range − range_ref| / range_ref: ``range_err_p50``, ``range_err_p95``,
``range_within_5pct`` (fraction with e ≤ 0.05), ``vpls``; per ray, the ``rays`` metrics (hit agreement
within the miss range, distance errors ÷ diagonal, self hits); ``rays_per_s`` = 6N / the median of the
method's ``raycast`` stage, ``oracle_rays_per_s``.

Parameters: docs/reference/parameters.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ldbench.core import conventions as conv
from ldbench.core.conventions import hash01, hash32, tangent_frame as frame  # noqa: F401 (re-exported)
from ldbench.core.errors import LdbenchError
from ldbench.core.imageio import save_image, save_map
from ldbench.core.params import ParamsBase, param

from .base import EffectSpec
from .rays import RayBatch, Rays, ray_metrics

# Start-up: ldbench.core.scene (about 8 ms) is imported by rsm_camera() alone; the CLI imports every effect module
# while it builds its parser, and nothing else here needs the scene module.

RAYS_PER_VPL = 5 + 1
#: Peak host memory per RSM texel (one VPL and its six rays): 700 B measured (maximum RSS of ``ldbench export``,
#: cornell, rsm 64 against 512), rounded up, for every texel (an upper bound: only lit texels are VPLs).
VPL_BYTES = 768
VPL_METRICS = ("range_err_p50", "range_err_p95", "range_within_5pct", "vpls", "hit_agreement",
               "false_hit_rate", "false_miss_rate", "dist_err_p50", "dist_err_p95", "dist_err_p99",
               "self_hit_rate", "coverage", "rays", "rays_per_s", "oracle_rays_per_s")
MIN_COS = 0.05  # a texel's footprint on a surface seen at grazing angles is clamped to 20× the texel


@dataclass(frozen=True)
class VplRangeParams(ParamsBase):
    rsm: int = param(256, "reflective shadow map side R: R^2 texels, one VPL per lit texel", lo=4, hi=4096,
                     paper="256 (Table 1); 256-2048 (Table 3)")
    primary: str = param("normal", "primary ray direction: the VPL's normal or the reflected light direction",
                         choices=("normal", "reflected"), paper="either")
    cone_angle: float = param(45.0, "angle between the primary ray and the five around it (degrees)",
                              lo=0.0, hi=89.0, paper="not published")
    range_mode: str = param("mean", "range = mean or max of the six clamped hit distances",
                            choices=("mean", "max"), paper="either")
    miss_range: float = param(0.25, "distance of a ray that misses (and clamp of every distance), as a "
                              "fraction of the scene diagonal", lo=1e-4, hi=10.0, paper="not published")


# ---------------------------------------------------------------------------------------------------
# the definition, in numpy (the GLSL twin is ldbench/methods/cdi_vpl/vpl.glsl; hash, frame, origin and reduction
# are ldbench/core/conventions.py's)


def primary_direction(normal: np.ndarray, incident: np.ndarray, primary: str) -> np.ndarray:
    n = np.asarray(normal, np.float64)
    if primary == "normal":
        return n / np.linalg.norm(n, axis=1, keepdims=True)
    w = np.asarray(incident, np.float64)
    r = w - 2.0 * (w * n).sum(1, keepdims=True) * n
    return r / np.linalg.norm(r, axis=1, keepdims=True)


def vpl_directions(normal, incident, texel, *, primary: str, cone_angle: float, seed: int) -> np.ndarray:
    """(N, 6, 3) float64 unit directions of the six rays of each VPL (module docstring)."""
    p = primary_direction(normal, incident, primary)
    t, b = frame(p)
    phi0 = 2.0 * np.pi * hash01(texel, seed)
    k = np.arange(5)
    phi = phi0[:, None] + k[None, :] * (2.0 * np.pi / 5.0)
    ca, sa = math.cos(math.radians(cone_angle)), math.sin(math.radians(cone_angle))
    around = (p[:, None] * ca + t[:, None] * (sa * np.cos(phi))[..., None]
              + b[:, None] * (sa * np.sin(phi))[..., None])
    d = np.concatenate([p[:, None], around], axis=1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def ray_origins(position, normal, ray_epsilon: float) -> np.ndarray:
    """The rays' common origin per VPL: :func:`ldbench.core.conventions.spawn_origin` (y is the crease point)."""
    return conv.spawn_origin(position, normal, ray_epsilon)


def reduce_ranges(t: np.ndarray, cap: float, mode: str) -> np.ndarray:
    """Per-VPL range from the six distances (6N,): :func:`ldbench.core.conventions.reduce_range`."""
    return conv.reduce_range(t, cap, mode, RAYS_PER_VPL)


def rsm_up(light) -> tuple:
    """The light's up vector, or a world axis when it is parallel to the spot axis."""
    d = np.asarray(light.direction(), np.float64)
    u = np.asarray(light.up, np.float64)
    if np.linalg.norm(np.cross(d, u)) > 1e-6 * max(float(np.linalg.norm(u)), 1e-30):
        return tuple(u)
    return tuple(np.eye(3)[int(np.argmin(np.abs(d)))])


def rsm_camera(light):
    """The RSM's view: from the light along its axis, square, vertical field of view 2 × cut-off."""
    from ldbench.core.scene import Camera

    if light.is_point or light.cutoff_angle >= 80.0:
        raise LdbenchError(f"a reflective shadow map needs a spot light with a cut-off below 80° (one "
                           f"perspective view); this light's is {light.cutoff_angle:g}°")
    return Camera(tuple(light.position), tuple(light.target), rsm_up(light), 2.0 * light.cutoff_angle)


def texel_solid_angle(light, R: int, directions: np.ndarray) -> np.ndarray:
    """Solid angle of the RSM texels whose centre directions are given: (2 tan(cut-off) / R)² · cos³α,
    α = the angle to the spot axis (the texel-centre approximation of the exact integral)."""
    t = math.tan(math.radians(light.cutoff_angle))
    cos_a = np.clip(np.asarray(directions, np.float64) @ np.asarray(light.direction(), np.float64), 0.0, 1.0)
    return (2.0 * t / R) ** 2 * cos_a ** 3


# ---------------------------------------------------------------------------------------------------
# inputs and reference


@dataclass
class VplBatch:
    """The VPLs of an RSM and their six rays each (see the module docstring)."""

    position: np.ndarray   # (N, 3) float32
    normal: np.ndarray     # (N, 3) facing the light
    incident: np.ndarray   # (N, 3) light → VPL
    flux: np.ndarray       # (N, 3) W
    area: np.ndarray       # (N,) m², the texel's footprint
    texel: np.ndarray      # (N,) uint32, row-major RSM texel (row 0 = top)
    rsm: int
    rays: object           # ldbench.core.effects.rays.RayBatch of 6N rays (VPL-major), t_max = cap
    cap: float             # the miss range in world units
    mode: str
    seed: int = 0
    _gpu: dict = field(default_factory=dict, repr=False)

    def __len__(self):
        return len(self.texel)

    def upload(self, gpu):
        """The rays on the GPU (one SSBO, uploaded once outside the timed frames)."""
        return self.rays.upload(gpu)

    def release(self):
        self.rays.release()

    def image(self, values: np.ndarray, fill=np.nan) -> np.ndarray:
        """Per-VPL values as an R × R × 1 map of the RSM (``fill`` where no VPL)."""
        out = np.full(self.rsm * self.rsm, fill, np.float32)
        out[self.texel] = values
        return out.reshape(self.rsm, self.rsm, 1)


@dataclass
class VplRangeReference:
    range: np.ndarray          # (N,) exact ranges
    t: np.ndarray              # (6N,) exact distances (inf = miss)
    seconds: float
    timing: str
    meta: dict = field(default_factory=dict)

    @property
    def rays_per_s(self) -> float:
        return len(self.t) / self.seconds if self.seconds > 0 else math.nan

    @property
    def mask(self):  # the runner's sanity check: something to compare
        return np.ones(1, bool) if len(self.range) else np.zeros(1, bool)


def make_vpls(scene, params: VplRangeParams, seed: int, exact) -> VplBatch:
    """The :class:`VplBatch` of ``params`` (an ``rsm``² RSM, six rays per VPL), from the exact first hits
    of the RSM rays and the ray epsilon of ``exact`` (:mod:`ldbench.core.effects.base`)."""
    if exact is None:
        raise LdbenchError("the vpl_range effect builds its VPLs from exact RSM hits: pass exact=")
    if not scene.lights:
        raise LdbenchError(f"scene {scene.name!r} has no light: no reflective shadow map")
    R = int(params.rsm)
    light = scene.lights[0]
    hits = exact.rsm_hits(scene, R)
    d = hits["direction"]
    fall = light.falloff(d @ np.asarray(light.direction(), np.float64))
    keep = hits["mask"] & (fall > 0)
    texel = np.flatnonzero(keep).astype(np.uint32)
    if len(texel) == 0:
        raise LdbenchError(f"scene {scene.name!r}: the light's RSM at {R}x{R} sees no geometry, no VPLs")
    y = hits["position"][keep].astype(np.float64)
    n = hits["normal"][keep].astype(np.float64)
    w = d[keep]
    omega = texel_solid_angle(light, R, w)
    flux = hits["albedo"][keep] * np.asarray(light.intensity)[None] * (fall[keep] * omega)[:, None]
    dist2 = ((y - np.asarray(light.position)) ** 2).sum(1)
    area = omega * dist2 / np.maximum(np.abs((n * w).sum(1)), MIN_COS)
    ray_eps, _ = exact.epsilons()
    dirs = vpl_directions(n, w, texel, primary=params.primary, cone_angle=params.cone_angle, seed=seed)
    o = np.repeat(ray_origins(hits["spawn"][keep].astype(np.float64), n, ray_eps), RAYS_PER_VPL, axis=0)
    cap = float(params.miss_range) * scene.diagonal()
    f4 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
    nn = np.repeat(n, RAYS_PER_VPL, axis=0)
    rays = RayBatch(f4(o), f4(dirs.reshape(-1, 3)), np.full(len(o), cap, np.float32), f4(nn),
                    np.repeat(texel, RAYS_PER_VPL), R, R, "vpl", occlusion=False,
                    primary_mask=keep.reshape(R, R))
    return VplBatch(position=f4(y), normal=f4(n), incident=f4(w), flux=f4(flux), area=f4(area), texel=texel,
                    rsm=R, rays=rays, cap=cap, mode=params.range_mode, seed=int(seed))


def range_metrics(r: np.ndarray, r_ref: np.ndarray) -> dict:
    """Relative range errors: p50, p95 and the fraction within 5 % (NaN answers count as wrong)."""
    r = np.asarray(r, np.float64)
    r_ref = np.asarray(r_ref, np.float64)
    if len(r_ref) == 0:
        raise LdbenchError("no VPLs: the light's RSM sees no geometry")
    with np.errstate(invalid="ignore", divide="ignore"):
        e = np.abs(r - r_ref) / np.maximum(r_ref, 1e-30)
    big = 1e300  # a NaN answer is an infinite error (percentiles interpolate, so not inf itself)
    p50, p95 = (float(x) if x < 1e-10 * big else math.inf for x in np.percentile(np.where(np.isnan(e), big, e), [50, 95]))
    e = np.where(np.isnan(e), np.inf, e)
    return {"range_err_p50": float(p50), "range_err_p95": float(p95),
            "range_within_5pct": float(np.mean(e <= 0.05)), "vpls": int(len(r_ref))}


class VplRange(EffectSpec):
    name = "vpl_range"
    Params = VplRangeParams
    output = "vpls"
    needs_light = True
    reference_key = "vpl_range"
    reference_backend = "Mitsuba 3: RSM by ray_intersect from the light; oracle ray_intersect_preliminary on the same rays"
    metrics = VPL_METRICS
    columns = {"range_err_p50": "float", "range_err_p95": "float", "range_within_5pct": "float", "vpls": "int",
               **Rays.columns}
    units = "range (scene units)"
    answer_key = "range"
    gate = (("range_within_5pct", "higher", 0.002, 0.0), ("range_err_p95", "lower", 1e-4, 0.10))
    supersedes = ("rsm", "primary", "cone_angle", "range_mode", "miss_range")  # the VPLs are the harness's

    def error_label(self):
        return "relative range error per RSM texel"

    def stochastic(self, params):
        return False

    def label(self, params):
        return (f"vpl_range-r{params.rsm}-{params.primary}-a{params.cone_angle:g}-{params.range_mode}"
                f"-m{params.miss_range:g}")

    def inputs(self, scene, width, height, params, seed, exact=None):
        return make_vpls(scene, params, seed, exact)

    def input_bytes(self, params, width, height):
        return params.rsm * params.rsm * VPL_BYTES

    def export_arrays(self, batch, width, height):
        r = batch.rays
        return (dict(position=batch.position, normal=batch.normal, incident=batch.incident, flux=batch.flux,
                     area=batch.area, texel=batch.texel, rsm=batch.rsm, cap=batch.cap, mode=batch.mode,
                     ray_origin=r.origin, ray_direction=r.direction, ray_tmax=r.tmax, ray_normal=r.normal),
                "VPLs and their 6 rays each (VPL-major); answer: range per VPL (and t per ray), "
                "range = mode of min(t, cap) over the six rays")

    def answer_arrays(self, result, reference, batch):
        r = batch.rays
        t = result.arrays.get("t")
        t = np.full(len(r), np.nan, np.float32) if t is None else np.asarray(t, np.float32).reshape(-1)
        return {"position": batch.position, "normal": batch.normal, "incident": batch.incident, "flux": batch.flux,
                "area": batch.area, "texel": batch.texel, "ray_origin": r.origin, "ray_direction": r.direction,
                "ray_tmax": r.tmax, "range": np.asarray(result.arrays.get("range"), np.float32).reshape(-1),
                "range_ref": np.asarray(reference.range, np.float32), "t": t,
                "t_ref": np.asarray(reference.t, np.float32), "cap": batch.cap, "mode": batch.mode, "rsm": batch.rsm}

    def _arrays(self, result, batch, count=False):
        """(ranges, distances), the values with no meaning (a range of ±inf, a distance of -inf) made NaN,
        i.e. unanswered; with ``count``, also how many there were."""
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: inf
            r = np.asarray(result.arrays.get("range"), np.float32).reshape(-1)
            t = result.arrays.get("t")
            t = np.full(len(batch.rays), np.nan, np.float32) if t is None else np.asarray(t, np.float32).reshape(-1)
        if r.shape != (len(batch),) or t.shape != (len(batch.rays),):
            raise LdbenchError(f"a method returned {r.shape[0]} ranges / {t.shape[0]} distances for "
                               f"{len(batch)} VPLs with {len(batch.rays)} rays")
        bad_r, bad_t = np.isinf(r), np.isneginf(t)
        r, t = np.where(bad_r, np.float32(np.nan), r), np.where(bad_t, np.float32(np.nan), t)
        return (r, t, int(np.count_nonzero(bad_r) + np.count_nonzero(bad_t))) if count else (r, t)

    def score(self, result, reference, *, scene, inputs, stage_ms):
        batch = inputs
        r, t, nonfinite = self._arrays(result, batch, count=True)
        m = range_metrics(r, reference.range)
        m["nonfinite"] = nonfinite
        has_t = not np.all(np.isnan(t))
        if has_t:
            m.update(ray_metrics(t, reference.t, tmax=batch.rays.tmax, occlusion=False, diagonal=scene.diagonal()))
        m["rays"] = len(batch.rays)
        ms = (stage_ms or {}).get("raycast")
        m["rays_per_s"] = len(batch.rays) / (ms * 1e-3) if ms and has_t else math.nan
        m["oracle_rays_per_s"] = reference.rays_per_s
        m["oracle_timing"] = reference.timing
        m["metric_settings"] = {
            "range_error": "|range - range_ref| / range_ref per VPL; within_5pct: fraction <= 0.05",
            "miss_range": batch.cap, "range_mode": batch.mode, "rays_per_vpl": RAYS_PER_VPL,
            "rays_per_s": "6 N / median GPU time of the method's 'raycast' stage",
            "oracle_timing": reference.timing, "diagonal": scene.diagonal(),
        }
        return m

    def save(self, result, reference, inputs, folder, label, ref_label):
        batch = inputs
        r, _ = self._arrays(result, batch)
        step = max(1, batch.rsm // 512)  # previews of at most 512² texels
        sub = lambda a: np.nan_to_num(a[::step, ::step], nan=0.0)  # noqa: E731
        ref_img, img = batch.image(reference.range), batch.image(r)
        scale = float(np.percentile(reference.range, 99)) if len(reference.range) else 1.0
        if not (folder / f"{ref_label}.exr").exists():
            save_image(folder / ref_label, sub(ref_img), png_scale=scale)
        save_image(folder / label, sub(img), png_scale=scale)
        with np.errstate(invalid="ignore", divide="ignore"):
            e = np.abs(img - ref_img) / np.maximum(ref_img, 1e-30)
        valid = ~np.isnan(ref_img[..., 0])
        vmax = save_map(folder / f"{label}-error", sub(e)[..., 0], valid[::step, ::step])
        return {"image": f"{label}.png", "exr": f"{label}.exr", "error_exr": f"{label}-error.exr",
                "reference": f"{ref_label}.png", "error_vmax": vmax,
                "image_meaning": "per RSM texel: VPL range (white = the reference's 99th percentile); "
                                 "error: relative range error"}

    def noise(self, reference) -> dict:
        return {"rms_std_of_mean": 0.0, "spp": None, "exact": True}
