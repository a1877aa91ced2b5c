"""``render_reference``: Mitsuba 3 ground truth of an effect, with per-pixel variance and a disk cache.

See :mod:`ldbench.references.integrators` for the exact estimators. Per-pixel statistics: with N = spp samples
v₁…v_N of a pixel,

    mean      = S₁ / N                         (S₁ = Σ vᵢ, S₂ = Σ vᵢ², accumulated in float64)
    variance  = (S₂ − S₁²/N) / (N − 1) / N     (unbiased sample variance divided by N: the variance of
                                                the *mean* estimate)

``variance`` is 0 for ``direct`` (deterministic: one exact evaluation per pixel, whatever spp is asked
for; the cache key then uses spp = 1), and ``inf`` on hit pixels when a stochastic effect is rendered
with spp = 1 (unknown). Background pixels have variance 0 and hold 1 (``ao``) or 0 (radiance).
"""
from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError

from . import cache as _cache
from . import integrators as _int
from .variant import choose_variant, mitsuba_version, variant_active

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them. tqdm is optional here (no progress bar
# without it).

# Samples (secondary rays) per wavefront, by variant. On the CPU 2^22 keeps the indirect wavefront (full
# surface interactions plus shadow rays) well under 1 GB at no loss of speed; on a GPU 2^24 is about
# twice as fast as 2^22 (measured on an H200: ~1.9 G AO rays/s).
BATCH_RAYS = {"llvm_ad_rgb": 1 << 22, "cuda_ad_rgb": 1 << 24}


@dataclass
class Reference:
    """A reference image: ``mean`` and ``variance`` (H×W×C float32, variance of the mean), ``mask`` (H×W bool)."""

    mean: np.ndarray
    variance: np.ndarray
    mask: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def stderr(self) -> np.ndarray:
        """Per-pixel standard error of ``mean``."""
        return np.sqrt(self.variance)


def _check_args(scene, effect, width, height, spp, seed):
    if isinstance(effect, str):
        effect = Effect.parse(effect)
    if not isinstance(effect, Effect):
        raise LdbenchError(f"effect must be a ldbench.core.effects.Effect, got {type(effect).__name__}")
    if effect.name not in _int.RENDERABLE:
        raise LdbenchError(f"the Mitsuba reference does not render effect {effect.name}")
    for what, v in (("width", width), ("height", height), ("spp", spp)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise LdbenchError(f"reference {what} must be a positive integer, got {v!r}")
    if int(width) * int(height) > (1 << 28):
        raise LdbenchError(f"reference size {width}x{height} is too large")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise LdbenchError(f"reference seed must be an integer, got {seed!r}")
    effect.check_scene(scene)
    return effect


def mix_seed(seed: int) -> int:
    x = (int(seed) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & ((1 << 64) - 1)
    x ^= x >> 29
    x = (x * 0xBF58476D1CE4E5B9) & ((1 << 64) - 1)
    return (x ^ (x >> 32)) & 0xFFFFFFFF


def progress_bar(total, desc, enabled):
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        enabled = False
        tqdm = None
    on = bool(enabled) and sys.stderr.isatty()
    if tqdm is None or not on:
        class _Null:
            def update(self, n=1):
                pass

            def close(self):
                pass
        return _Null()
    return tqdm(total=total, desc=desc, unit="sample", unit_scale=True, leave=False, file=sys.stderr)


def _render(scene, effect, width, height, spp, seed, progress, batch_rays):
    import drjit as dr
    import mitsuba as mi

    mscene = _int.build_scene(scene, with_lights=effect.name != "ao")
    o, d = _int.primary_rays(scene, width, height)
    npix = width * height
    C = effect.spec.channels
    background = effect.spec.background
    mean = np.full((npix, C), background, np.float64)
    var = np.zeros((npix, C), np.float64)
    mask = np.zeros(npix, bool)
    stochastic = effect.spec.stochastic(effect.params)
    seed_key = dr.opaque(mi.UInt32, mix_seed(seed))
    chunk = max(1, min(npix, batch_rays))
    bar = progress_bar(npix * (spp if stochastic else 1), f"reference {scene.name} {effect.label()}", progress)
    try:
        for c0 in range(0, npix, chunk):
            c1 = min(npix, c0 + chunk)
            ray, si = _int.trace_primary(mi, dr, mscene, o[c0:c1], d[c0:c1])
            valid = si.is_valid()
            if not stochastic:
                L = _int.direct_light(mi, dr, mscene, si, valid)
                dr.eval(L, valid)
                m = _int.np1(valid).astype(bool)
                mask[c0:c1] = m
                mean[c0:c1] = np.where(m[:, None], _int.np3(L), 0.0)
                bar.update(c1 - c0)
                continue
            n = _int.facing_normal(dr, si, ray.d)
            alb = si.bsdf().eval_diffuse_reflectance(si, valid) if effect.name == "indirect" else None
            p_hit = _int.vec(mi, mi.Point3f, _int.spawn_points(si))  # crease points; sample_values spawns
            dr.eval(valid, p_hit, n, alb)
            m = _int.np1(valid).astype(bool)
            mask[c0:c1] = m
            idx = np.nonzero(m)[0].astype(np.uint32)
            bar.update((c1 - c0 - len(idx)) * spp)
            if len(idx) == 0:
                continue
            vidx = mi.UInt32(idx)
            P = dr.gather(mi.Point3f, mi.Point3f(p_hit), vidx)
            N = dr.gather(mi.Vector3f, mi.Vector3f(n), vidx)
            A = dr.gather(mi.Color3f, mi.Color3f(alb), vidx) if alb is not None else None
            pix = mi.UInt32(idx + np.uint32(c0))
            dr.eval(P, N, A, pix)
            del ray, si, n, alb, valid, p_hit
            nv = len(idx)
            ns = max(1, min(spp, batch_rays // nv))
            S1 = np.zeros((nv, C), np.float64)
            S2 = np.zeros((nv, C), np.float64)
            for s0 in range(0, spp, ns):
                k = min(ns, spp - s0)
                lanes = nv * k
                i = dr.arange(mi.UInt32, lanes)
                kk = dr.opaque(mi.UInt32, k)
                j = i // kk  # lane → compacted pixel (pixel-major: k consecutive lanes per pixel)
                s = i - j * kk + dr.opaque(mi.UInt32, s0)
                lp = dr.gather(mi.Point3f, P, j)
                ln = dr.gather(mi.Vector3f, N, j)
                la = dr.gather(mi.Color3f, A, j) if A is not None else None
                lpix = dr.gather(mi.UInt32, pix, j)
                v = _int.sample_values(mi, dr, mscene, effect, lp, ln, la, lpix, s, seed_key)
                comps = [v] if C == 1 else [v[0], v[1], v[2]]
                comps = [mi.Float64(c) for c in comps]
                dr.eval(comps)
                for c, x in enumerate(comps):
                    S1[:, c] += _int.np1(dr.block_sum(x, k))
                    S2[:, c] += _int.np1(dr.block_sum(x * x, k))
                del v, comps, lp, ln, la, lpix, i, j, s
                bar.update(lanes)
            mu = S1 / spp
            if spp > 1:
                vm = np.maximum(S2 - S1 * mu, 0.0) / (spp * (spp - 1.0))
            else:
                vm = np.full_like(mu, np.inf)
            gidx = idx.astype(np.int64) + c0
            mean[gidx] = mu
            var[gidx] = vm
    finally:
        bar.close()
    H, W = height, width
    return (mean.reshape(H, W, C).astype(np.float32), var.reshape(H, W, C).astype(np.float32),
            mask.reshape(H, W))


def render_reference(scene, effect, *, width: int, height: int, spp: int = 1024, cache: bool = True,
                     cache_dir=None, progress: bool = True, seed: int = 0,
                     batch_rays: int | None = None) -> Reference:
    """Render (or fetch from the cache) the Mitsuba 3 reference of ``effect`` on ``scene``.

    ``effect``: a :class:`ldbench.core.effects.Effect` (``ao``, ``direct`` or ``indirect``; an effect name is
    accepted too). Primary rays go through pixel centres of ``scene.camera`` at ``width × height``.
    ``spp`` samples per pixel for ``ao`` and ``indirect``; ``direct`` is exact with one evaluation.
    Deterministic for a given ``seed`` (independent of ``batch_rays``, the wavefront size; default
    :data:`BATCH_RAYS` of the variant).
    With ``cache``, looks up / stores ``<cache_dir>/<key>.exr`` (see :mod:`ldbench.references.cache`).

    Returns a :class:`Reference`; ``meta`` holds ``variant``, ``mitsuba_version``, ``spp``,
    ``spp_requested``, ``seconds`` (render time; that of the original render on a cache hit), ``key``,
    ``cached``, ``effect`` and ``rays_per_second``. Every failure is a one-line :class:`LdbenchError`.
    """
    effect = _check_args(scene, effect, width, height, spp, seed)
    width, height, spp, seed = int(width), int(height), int(spp), int(seed)
    if batch_rays is not None and (isinstance(batch_rays, bool) or not isinstance(batch_rays, (int, np.integer))
                                   or batch_rays < 1):
        raise LdbenchError(f"batch_rays must be a positive integer, got {batch_rays!r}")
    spp_eff = spp if effect.spec.stochastic(effect.params) else 1

    variant = choose_variant()
    if batch_rays is None:
        batch_rays = BATCH_RAYS.get(variant, 1 << 22)
    nl = len(scene.lights)
    per_sample = {"ao": 1, "direct": nl, "indirect": 1 + nl}[effect.name]
    return cached_render(scene, effect, width, height, spp_eff, spp, seed, variant, cache, cache_dir, per_sample,
                         lambda: _render(scene, effect, width, height, spp_eff, seed, progress, int(batch_rays)))


def cached_render(scene, effect, width: int, height: int, spp: int, spp_requested: int, seed: int, variant: str,
                  cache: bool, cache_dir, rays_per_sample: int, render) -> Reference:
    """The cache lookup, ``render()`` → (mean, var, mask) under ``variant`` on a miss, its checks, timing,
    metadata and storing: what every reference renderer shares (this module and :mod:`ldbench.references.wavefront`).
    ``rays_per_sample``: rays per sample of a hit pixel, for ``rays_per_second`` (one primary ray per pixel
    besides)."""
    with variant_active(variant):
        version = mitsuba_version()
        fields = _cache.key_fields(scene, effect, width, height, spp, seed, version, variant)
        key = _cache.cache_key(fields)
        cdir = Path(cache_dir) if cache_dir is not None else _cache.default_cache_dir()
        if cache:
            hit = _cache.load(cdir, key, fields)
            if hit is not None:
                mean, var, mask, meta = hit
                meta.update(cached=True, key=key, spp_requested=spp_requested)
                return Reference(mean, var, mask, meta)
        t0 = time.perf_counter()
        try:
            mean, var, mask = render()
        except (RuntimeError, MemoryError) as e:  # Dr.Jit/Mitsuba failures (e.g. out of memory)
            msg = (str(e).strip().splitlines() or [type(e).__name__])[0]
            raise LdbenchError(f"Mitsuba ({variant}) failed rendering {effect.label()} on {scene.name!r}: "
                               f"{msg}") from e
        seconds = time.perf_counter() - t0
        if not (np.all(np.isfinite(mean))):
            raise LdbenchError(f"the Mitsuba reference of {effect.label()} on {scene.name!r} produced "
                               f"non-finite values")
        rays = width * height + int(mask.sum()) * spp * rays_per_sample
        meta = {
            "variant": variant, "mitsuba_version": version, "spp": spp, "spp_requested": spp_requested,
            "seconds": seconds, "key": key, "cached": False, "effect": effect.key(), "seed": seed,
            "width": width, "height": height, "scene": scene.name, "scene_hash": fields["scene"],
            "reference_version": _cache.REFERENCE_VERSION,
            "rays_per_second": rays / seconds if seconds > 0 else math.inf,
        }
        if cache:
            try:
                _cache.store(cdir, key, fields, mean, var, mask, meta)
            except LdbenchError as e:  # the reference itself is fine: keep it, say why it is not cached
                warnings.warn(f"reference not cached: {e}", RuntimeWarning, stacklevel=2)
        return Reference(mean, var, mask, meta)


def primary_hits(scene, width: int, height: int) -> dict:
    """Mitsuba's primary hits through pixel centres, for validating G-buffers and in tests.

    Returns ``mask`` (H×W bool), ``position`` (H×W×3 float32, world space, 0 on background),
    ``spawn`` (where secondary rays start before their offset: ``position`` moved off triangle edges,
    :func:`ldbench.core.conventions.crease_point`), ``normal`` (H×W×3, geometric normal facing the camera),
    ``distance`` (H×W, ray t; inf on background) and ``albedo`` (H×W×3).
    """
    variant = choose_variant()
    import drjit as dr

    with variant_active(variant) as mi:
        mscene = _int.build_scene(scene, with_lights=False)
        o, d = _int.primary_rays(scene, width, height)
        ray, si = _int.trace_primary(mi, dr, mscene, o, d)
        valid = si.is_valid()
        n = _int.facing_normal(dr, si, ray.d)
        alb = si.bsdf().eval_diffuse_reflectance(si, valid)
        dr.eval(valid, si.p, si.t, n, alb)
        m = _int.np1(valid).astype(bool)
        H, W = height, width
        z3 = lambda a: np.where(m[:, None], a, 0.0).astype(np.float32).reshape(H, W, 3)  # noqa: E731
        return {
            "mask": m.reshape(H, W),
            "position": z3(_int.np3(si.p)),
            "spawn": z3(_int.spawn_points(si)),
            "normal": z3(_int.np3(n)),
            "distance": np.where(m, _int.np1(si.t), np.inf).astype(np.float32).reshape(H, W),
            "albedo": z3(_int.np3(mi.Color3f(alb))),
        }
