"""``rays``: ray queries checked ray by ray against Mitsuba's exact intersection.

The harness builds one **ray batch** per (scene, view, parameters, seed) and hands the same float32
arrays to the method and to the oracle:

1. **Primary hits**: Mitsuba's exact intersection of the pixel-centre camera rays (the reference's own
   primary hits), so both sides start from the same surface points x with the same geometric normal n
   flipped to face the camera.
2. **Origin** (:func:`ldbench.core.conventions.spawn_origin`): o = x' + ε n with ε = (1 + max|x'|) · Mitsuba's
   ``RayEpsilon`` (8.94e-5 for float32 variants), Mitsuba's ``spawn_ray`` offset, where x' is x except
   within a few ε of an edge of its triangle (:func:`ldbench.core.conventions.crease_point`, the hits'
   ``spawn``): a pixel centre exactly on a crease would otherwise start inside the neighbouring wall's
   plane. It is the origin of the ``ao`` and ``indirect`` references. A ray into the surface (a shadow
   ray towards a light point below the tangent plane) starts on the camera's side and meets the surface
   at once.
3. ``rays_per_pixel`` rays per hit pixel, of one ``ray_kind``:

   ==========  =========================================================================  ===============
   kind        direction                                                                  t_max
   ==========  =========================================================================  ===============
   diffuse     cosine-distributed about n                                                 ∞
   glossy      normalized Phong lobe (e+1)/(2π) cos^e α about the mirror direction of     ∞
               d_cam; a sample below the surface is mirrored about the tangent plane
   shadow      towards a point uniform (by area) on the sphere of ``light_radius`` around  distance · (1 −
               the scene's first light; the answer is blocked / unblocked before it        ShadowEpsilon)
   ao          cosine-distributed about n                                                 ``d_max``
   ==========  =========================================================================  ===============

   Random numbers, frame and warps: :mod:`ldbench.core.conventions` (numpy's PCG64 seeded with (seed, kind),
   two uniforms per ray, pixel-major order; its docstring says how to regenerate a batch).

**Inputs** (:class:`RayBatch`): ``origin``, ``direction`` (unit), ``tmax`` (float32, ∞ allowed) and
``normal`` (n at the origin, for methods whose self-intersection rule needs it), ``pixel`` (the
row-major pixel index, row 0 at the top). On the GPU (:meth:`RayBatch.upload`) they are one SSBO of
``vec4(origin, tmax), vec4(direction, 0), vec4(normal, 0)`` per ray (``ldbench/methods/glsl/common/rays.glsl``).

**A method returns** ``arrays["t"]``: the hit distance per ray (``inf`` = miss; NaN = no answer, which
counts as a wrong answer; ``-inf`` means nothing: it counts as no answer and in ``nonfinite``, and makes
the row ``degraded``), optionally ``arrays["normal"]``.

**Oracle** (:mod:`ldbench.references.rays`): Mitsuba on the same triangles, one wavefront:
``ray_intersect_preliminary`` for closest hits, ``ray_test`` for shadow rays (blocked → t = 0).

**Metrics** (columns):

- ``hit_agreement`` = 1 − ``false_hit_rate`` − ``false_miss_rate`` − (unanswered rays)/N; a false hit is a
  method hit where the oracle misses, a false miss the reverse, both as fractions of all N rays;
- ``dist_err_p50/p95/p99``: |t − t_ref| / scene diagonal over rays that both hit (not for shadow rays);
- ``self_hit_rate``: rays the method reports hitting closer than 0.5 % of the diagonal where the oracle's
  hit is farther (or missing): hits on the origin's own surface;
- ``coverage``: answered rays / N;
- ``rays_per_s``: N / the median GPU time of the method's ``trace`` stage alone;
- ``oracle_rays_per_s``: N / the oracle's time on the same batch on the same machine, from Dr.Jit's kernel
  device times (``dr.kernel_history()``, code generation excluded) on CUDA; on the CPU (LLVM) it is wall
  clock, and ``oracle_timing`` says which.

Images for the report: per pixel the fraction of rays that hit (method and oracle) and, as the error
map, the fraction of the pixel's rays on which they disagree.

Parameters: docs/reference/parameters.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ldbench.core import conventions as conv
from ldbench.core.errors import LdbenchError
from ldbench.core.imageio import save_image, save_map
from ldbench.core.params import ParamsBase, param

from .base import EffectSpec

KINDS = ("diffuse", "glossy", "shadow", "ao")
SELF_HIT_FRACTION = 0.005  # of the scene diagonal
#: Peak host memory per ray of a batch: 209 B measured (maximum RSS of ``ldbench export``, cornell at 128², 16
#: against 128 rays per pixel: float64 directions and frames while it is built, the saved arrays), 170 B in
#: ``run``; rounded up, for every pixel (an upper bound: only the pixels that hit get rays).
RAY_BYTES = 256
RAY_METRICS = ("hit_agreement", "false_hit_rate", "false_miss_rate", "dist_err_p50", "dist_err_p95",
               "dist_err_p99", "self_hit_rate", "coverage", "rays", "rays_per_s", "oracle_rays_per_s")


@dataclass(frozen=True)
class RaysParams(ParamsBase):
    ray_kind: str = param("diffuse", "the kind of every ray: diffuse (cosine about the normal), glossy (Phong "
                          "lobe about the mirror direction), shadow (towards a point of the spherical light) or ao "
                          "(cosine, t_max = d_max)", choices=KINDS)
    rays_per_pixel: int = param(4, "rays per hit pixel of the batch", lo=1, hi=1024)
    exponent: float = param(32.0, "glossy rays: normalized Phong exponent e", lo=0.0, hi=1e6)
    light_radius: float = param(0.1, "shadow rays: radius of the spherical light around the scene's first light "
                                "(world units)", lo=0.0, hi=1e6)
    d_max: float = param(math.inf, "ao rays: t_max of every ray (world units; inf: unbounded)")

    def __post_init__(self):
        super().__post_init__()
        if not self.d_max > 0:
            raise LdbenchError(f"effect parameter d_max must be > 0, got {self.d_max!r}")


@dataclass
class RayBatch:
    """A ray batch (float32 arrays, N rays); see the module docstring."""

    origin: np.ndarray      # (N, 3)
    direction: np.ndarray   # (N, 3), unit
    tmax: np.ndarray        # (N,)
    normal: np.ndarray      # (N, 3) surface normal at the origin, facing the camera
    pixel: np.ndarray       # (N,) uint32 row-major pixel index (row 0 = top)
    width: int
    height: int
    kind: str
    occlusion: bool         # shadow rays: only blocked / unblocked matters
    primary_mask: np.ndarray | None = None  # (H, W) pixels whose primary ray hit
    _gpu: dict = field(default_factory=dict, repr=False)

    def __len__(self):
        return len(self.tmax)

    def packed(self) -> np.ndarray:
        """(N, 12) float32: origin, tmax, direction, 0, normal, 0 (the GPU layout)."""
        a = np.zeros((len(self), 12), np.float32)
        a[:, 0:3], a[:, 3] = self.origin, self.tmax
        a[:, 4:7], a[:, 8:11] = self.direction, self.normal
        return a

    def upload(self, gpu):
        """The batch as one SSBO on ``gpu`` (uploaded once, outside timed regions)."""
        key = id(gpu.ctx)
        if key not in self._gpu:
            self._gpu[key] = gpu.ctx.buffer(self.packed().tobytes())
        return self._gpu[key]

    def release(self):
        for b in self._gpu.values():
            b.release()
        self._gpu.clear()

    def __getstate__(self) -> dict:
        """The arrays without the GPU buffers, which belong to the context that made them: a batch pickled to
        another process (a ``run --writers`` writer) scores there and is uploaded again where needed."""
        return {**self.__dict__, "_gpu": {}}


def build_batch(hits: dict, cam_dirs: np.ndarray, params: RaysParams, seed: int, *, light=None,
                ray_epsilon: float, shadow_epsilon: float) -> RayBatch:
    """The ray batch from primary hits (``ldbench.references.primary_hits``: ``spawn`` points, else ``position``) and
    the camera ray directions."""
    H, W = hits["mask"].shape
    pix = np.flatnonzero(hits["mask"].reshape(-1)).astype(np.uint32)
    k = params.rays_per_pixel
    x = hits.get("spawn", hits["position"]).reshape(-1, 3)[pix].astype(np.float64)
    n = hits["normal"].reshape(-1, 3)[pix].astype(np.float64)
    dc = cam_dirs.reshape(-1, 3)[pix].astype(np.float64)
    o = conv.spawn_origin(x, n, ray_epsilon)
    o, n, dc = (np.repeat(a, k, axis=0) for a in (o, n, dc))
    pixel = np.repeat(pix, k)
    u = conv.batch_uniforms(seed, KINDS.index(params.ray_kind), len(pixel))
    tmax = np.full(len(pixel), np.inf)
    if params.ray_kind in ("diffuse", "ao"):
        d = conv.cosine_direction(n, u)
        if params.ray_kind == "ao":
            tmax[:] = params.d_max
    elif params.ray_kind == "glossy":
        r = dc - 2.0 * (dc * n).sum(1, keepdims=True) * n
        d = conv.phong_direction(r, params.exponent, u)
        below = (d * n).sum(1) < 0
        d[below] -= 2.0 * (d[below] * n[below]).sum(1, keepdims=True) * n[below]
    else:  # shadow
        if light is None:
            raise LdbenchError("shadow rays need a light")
        p = conv.sphere_point(light.position, params.light_radius, u)
        d = p - o
        dist = np.linalg.norm(d, axis=1)
        d /= np.maximum(dist, 1e-30)[:, None]
        tmax = dist * (1.0 - shadow_epsilon)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    f4 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
    return RayBatch(f4(o), f4(d), f4(tmax), f4(n), pixel, W, H, params.ray_kind,
                    occlusion=params.ray_kind == "shadow")


def make_batch(scene, width: int, height: int, params: RaysParams, seed: int, exact) -> RayBatch:
    """The :class:`RayBatch` of ``params`` for this view, from the exact primary hits and epsilons of
    ``exact`` (:mod:`ldbench.core.effects.base`)."""
    if exact is None:
        raise LdbenchError("the rays effect builds its rays from exact primary hits: pass exact=")
    hits = exact.primary_hits(scene, width, height)
    if not hits["mask"].any():
        raise LdbenchError(f"scene {scene.name!r}: the camera sees no geometry, no rays to cast")
    _, dirs = scene.camera.primary_rays(width, height)
    ray_eps, shadow_eps = exact.epsilons()
    light = scene.lights[0] if scene.lights else None
    batch = build_batch(hits, dirs, params, seed, light=light, ray_epsilon=ray_eps, shadow_epsilon=shadow_eps)
    batch.primary_mask = hits["mask"]
    return batch


@dataclass
class RaysReference:
    """The oracle's answer on a batch: ``t`` (inf = miss, 0 = blocked shadow ray), timing, primary mask."""

    t: np.ndarray
    mask: np.ndarray           # (H, W) primary hits
    seconds: float             # oracle time for the batch (see ``timing``)
    timing: str                # "kernel" (Dr.Jit device times) or "wall"
    meta: dict = field(default_factory=dict)

    @property
    def rays_per_s(self) -> float:
        return len(self.t) / self.seconds if self.seconds > 0 else math.nan


def per_pixel(values: np.ndarray, pixel: np.ndarray, width: int, height: int, fill=0.0) -> np.ndarray:
    """Per-pixel mean of per-ray values (H, W, 1) float32; ``fill`` where a pixel has no ray."""
    n = width * height
    s = np.bincount(pixel, weights=values.astype(np.float64), minlength=n)
    c = np.bincount(pixel, minlength=n)
    out = np.where(c > 0, s / np.maximum(c, 1), fill)
    return out.reshape(height, width, 1).astype(np.float32)


def is_hit(t, tmax) -> np.ndarray:
    """A finite distance within t_max (NaN, unanswered, is not a hit)."""
    t = np.asarray(t)
    with np.errstate(invalid="ignore"):
        return np.isfinite(t) & (t <= tmax)


def ray_metrics(t: np.ndarray, t_ref: np.ndarray, *, tmax: np.ndarray, occlusion: bool, diagonal: float) -> dict:
    """The per-ray metrics of the module docstring (without the speeds)."""
    t = np.asarray(t, np.float64)
    t_ref = np.asarray(t_ref, np.float64)
    tmax = np.asarray(tmax, np.float64)
    n = len(t)
    if n == 0:
        raise LdbenchError("the ray batch is empty (the camera sees no geometry)")
    answered = ~np.isnan(t)
    hit, hit_ref = is_hit(t, tmax), is_hit(t_ref, tmax)
    fh = float(np.count_nonzero(hit & ~hit_ref)) / n
    fm = float(np.count_nonzero(answered & ~hit & hit_ref)) / n
    unanswered = float(np.count_nonzero(~answered)) / n
    both = hit & hit_ref
    out = {"hit_agreement": 1.0 - fh - fm - unanswered, "false_hit_rate": fh, "false_miss_rate": fm,
           "coverage": 1.0 - unanswered, "rays": n}
    if occlusion or not both.any():
        out.update(dist_err_p50=math.nan, dist_err_p95=math.nan, dist_err_p99=math.nan)
    else:
        e = np.abs(t[both] - t_ref[both]) / diagonal
        p50, p95, p99 = np.percentile(e, [50, 95, 99])
        out.update(dist_err_p50=float(p50), dist_err_p95=float(p95), dist_err_p99=float(p99))
    if occlusion:
        out["self_hit_rate"] = math.nan
    else:
        tau = SELF_HIT_FRACTION * diagonal
        out["self_hit_rate"] = float(np.count_nonzero(hit & (t < tau) & ~(hit_ref & (t_ref < 2 * tau)))) / n
    return out


class Rays(EffectSpec):
    name = "rays"
    Params = RaysParams
    output = "rays"
    reference_key = "rays"
    reference_backend = "Mitsuba 3 oracle: ray_intersect_preliminary / ray_test on the same rays"
    metrics = RAY_METRICS
    columns = {"hit_agreement": "float", "false_hit_rate": "float", "false_miss_rate": "float",
               "dist_err_p50": "float", "dist_err_p95": "float", "dist_err_p99": "float", "self_hit_rate": "float",
               "coverage": "float", "nonfinite": "int", "rays": "int", "rays_per_s": "float",
               "oracle_rays_per_s": "float", "oracle_timing": "str"}
    units = "fraction of rays that hit"
    answer_key = "t"
    # Exact answers on both sides: no reference noise, so fixed tolerances (absolute, relative).
    gate = (("hit_agreement", "higher", 0.002, 0.0), ("dist_err_p95", "lower", 1e-4, 0.10),
            ("self_hit_rate", "lower", 0.001, 0.0))

    def requires_light(self, params):
        return params.ray_kind == "shadow"

    def stochastic(self, params):
        return False  # exact answers: spp does not apply

    def label(self, params):
        extra = {"glossy": f"-e{params.exponent:g}", "shadow": f"-r{params.light_radius:g}",
                 "ao": f"-d{'inf' if math.isinf(params.d_max) else f'{params.d_max:g}'}"}.get(params.ray_kind, "")
        return f"rays-{params.ray_kind}{extra}-{params.rays_per_pixel}"

    def key(self, params):
        out = {"effect": "rays", "ray_kind": params.ray_kind, "rays_per_pixel": params.rays_per_pixel}
        if params.ray_kind == "glossy":
            out["exponent"] = params.exponent
        if params.ray_kind == "shadow":
            out["light_radius"] = params.light_radius
        if params.ray_kind == "ao":
            out["d_max"] = "inf" if math.isinf(params.d_max) else params.d_max
        return out

    def inputs(self, scene, width, height, params, seed, exact=None):
        return make_batch(scene, width, height, params, seed, exact)

    def input_bytes(self, params, width, height):
        return width * height * params.rays_per_pixel * RAY_BYTES

    def error_label(self):
        return "fraction of the pixel's rays where hit / miss disagree with the oracle"

    figures = ("rays",)

    def caption(self, row, f):
        rate = row["rays_per_s"]
        return [f"hit agreement {f(row['hit_agreement'], 4)} · p95 {f(row['dist_err_p95'], 4)}",
                f"self hits {f(row['self_hit_rate'], 4)} · {f(rate / 1e6 if rate is not None else None, 3)} Mrays/s"]

    def export_arrays(self, batch, width, height):
        return (dict(origin=batch.origin, direction=batch.direction, tmax=batch.tmax, normal=batch.normal,
                     pixel=batch.pixel, width=width, height=height, kind=batch.kind, occlusion=batch.occlusion),
                "rays: origin, direction, tmax, normal, pixel (row-major, row 0 at the top); answer: the hit "
                "distance t per ray, inf = miss (shadow rays: 0 = blocked)")

    def answer_arrays(self, result, reference, batch):
        t = np.asarray(result.arrays.get("t"), np.float32).reshape(-1)
        return {"origin": batch.origin, "direction": batch.direction, "tmax": batch.tmax, "normal": batch.normal,
                "pixel": batch.pixel, "t": t, "t_ref": np.asarray(reference.t, np.float32), "width": batch.width,
                "height": batch.height, "kind": batch.kind}

    def _t(self, result, batch, count=False):
        """The answers, a -inf (no meaning: inf is a miss, NaN no answer) made NaN, i.e. unanswered;
        with ``count``, (answers, how many were -inf)."""
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: inf
            t = np.asarray(result.arrays.get("t"), np.float32).reshape(-1)
        if t.shape != (len(batch),):
            raise LdbenchError(f"a method returned {t.shape[0]} ray answers for a batch of {len(batch)} rays")
        bad = np.isneginf(t)
        t = np.where(bad, np.float32(np.nan), t)
        return (t, int(np.count_nonzero(bad))) if count else t

    def score(self, result, reference, *, scene, inputs, stage_ms):
        batch = inputs
        t, nonfinite = self._t(result, batch, count=True)
        m = ray_metrics(t, reference.t, tmax=batch.tmax, occlusion=batch.occlusion, diagonal=scene.diagonal())
        m["nonfinite"] = nonfinite
        trace_ms = (stage_ms or {}).get("trace")
        m["rays_per_s"] = len(batch) / (trace_ms * 1e-3) if trace_ms else math.nan
        m["oracle_rays_per_s"] = reference.rays_per_s
        m["oracle_timing"] = reference.timing
        m["metric_settings"] = {
            "distance_error": "|t - t_ref| / scene diagonal over rays both hit",
            "diagonal": scene.diagonal(), "self_hit_threshold": SELF_HIT_FRACTION * scene.diagonal(),
            "rays_per_s": "rays / median GPU time of the method's 'trace' stage",
            "oracle_timing": reference.timing,
        }
        return m

    def save(self, result, reference, inputs, folder, label, ref_label):
        batch = inputs
        t = self._t(result, batch)
        W, H = batch.width, batch.height
        hit, hit_ref = is_hit(t, batch.tmax), is_hit(reference.t, batch.tmax)
        disagree = (np.isnan(t) | (hit != hit_ref)).astype(np.float64)
        hit, hit_ref = hit.astype(np.float64), hit_ref.astype(np.float64)
        if not (folder / f"{ref_label}.exr").exists():
            save_image(folder / ref_label, per_pixel(hit_ref, batch.pixel, W, H))
        save_image(folder / label, per_pixel(hit, batch.pixel, W, H))
        emap = per_pixel(disagree, batch.pixel, W, H)[..., 0]
        vmax = save_map(folder / f"{label}-error", emap, reference.mask)
        return {"image": f"{label}.png", "exr": f"{label}.exr", "error_exr": f"{label}-error.exr",
                "reference": f"{ref_label}.png", "error_vmax": vmax,
                "image_meaning": "per pixel: fraction of rays that hit; error: fraction that disagree"}

    def noise(self, reference) -> dict:
        return {"rms_std_of_mean": 0.0, "spp": None, "exact": True}
