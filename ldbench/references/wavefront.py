"""Image references of effects that bring their own Monte Carlo estimator (``glossy_indirect``,
``soft_shadows``): the wavefront loop, per-pixel statistics and cache of :func:`ldbench.references.render_reference`,
with the per-sample estimator given as a function.

:func:`render_estimator` traces the pixel-centre primary rays, keeps the hit pixels and evaluates
``estimator(mi, dr, mscene, scene, effect, lanes, pixel, sample, seed_key) -> Color3f`` for all (pixel, sample)
lanes of a wavefront, where ``lanes`` holds per-lane Dr.Jit arrays: ``p`` (the hit's crease point,
:func:`ldbench.references.integrators.spawn_points`; secondary rays start at
:func:`ldbench.references.integrators.spawn_origin` of it, as in render_reference), ``n`` (geometric normal facing the
camera), ``albedo``,
``d`` (the camera ray's direction) and ``direct`` (the unshadowed direct light leaving the hit towards
the camera, when ``needs_direct``). Random numbers: :func:`ldbench.references.integrators.rng2` (one PCG32
stream per pixel, sample index and seed). Mean and variance of the mean as in :mod:`ldbench.references.render`;
cached under the same key scheme (:mod:`ldbench.references.cache`).
"""
from __future__ import annotations

import numpy as np

from ldbench.core.errors import LdbenchError

from . import integrators as _int
from .render import BATCH_RAYS, Reference, cached_render, mix_seed, progress_bar
from .variant import choose_variant

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them.


def _render(scene, effect, width, height, spp, seed, progress, batch_rays, estimator, needs_direct):
    import drjit as dr
    import mitsuba as mi

    mscene = _int.build_scene(scene)
    o, d = _int.primary_rays(scene, width, height)
    npix = width * height
    mean = np.zeros((npix, 3), np.float64)
    var = np.zeros((npix, 3), np.float64)
    mask = np.zeros(npix, bool)
    seed_key = dr.opaque(mi.UInt32, mix_seed(seed))
    chunk = max(1, min(npix, batch_rays))
    bar = progress_bar(npix * spp, f"reference {scene.name} {effect.label()}", progress)
    try:
        for c0 in range(0, npix, chunk):
            c1 = min(npix, c0 + chunk)
            ray, si = _int.trace_primary(mi, dr, mscene, o[c0:c1], d[c0:c1])
            valid = si.is_valid()
            per_pixel = {"n": _int.facing_normal(dr, si, ray.d),
                         "albedo": mi.Color3f(si.bsdf().eval_diffuse_reflectance(si, valid)),
                         "d": mi.Vector3f(ray.d),
                         "p": _int.vec(mi, mi.Point3f, _int.spawn_points(si))}
            if needs_direct:
                per_pixel["direct"] = _int.direct_light(mi, dr, mscene, si, valid, shadows=False)
            dr.eval(valid, *per_pixel.values())
            m = _int.np1(valid).astype(bool)
            mask[c0:c1] = m
            idx = np.nonzero(m)[0].astype(np.uint32)
            bar.update((c1 - c0 - len(idx)) * spp)
            if len(idx) == 0:
                continue
            vidx = mi.UInt32(idx)
            packed = {k: dr.gather(type(v), v, vidx) for k, v in per_pixel.items()}
            pix = mi.UInt32(idx + np.uint32(c0))
            dr.eval(*packed.values(), pix)
            del ray, si, valid, per_pixel
            nv = len(idx)
            ns = max(1, min(spp, batch_rays // nv))
            S1 = np.zeros((nv, 3), np.float64)
            S2 = np.zeros((nv, 3), np.float64)
            for s0 in range(0, spp, ns):
                k = min(ns, spp - s0)
                i = dr.arange(mi.UInt32, nv * k)
                kk = dr.opaque(mi.UInt32, k)
                j = i // kk  # lane → compacted pixel (k consecutive lanes per pixel)
                s = i - j * kk + dr.opaque(mi.UInt32, s0)
                lanes = {key: dr.gather(type(v), v, j) for key, v in packed.items()}
                v = estimator(mi, dr, mscene, scene, effect, lanes, dr.gather(mi.UInt32, pix, j), s, seed_key)
                comps = [mi.Float64(v[c]) for c in range(3)]
                dr.eval(comps)
                for c, x in enumerate(comps):
                    S1[:, c] += _int.np1(dr.block_sum(x, k))
                    S2[:, c] += _int.np1(dr.block_sum(x * x, k))
                del v, comps, lanes, i, j, s
                bar.update(nv * k)
            mu = S1 / spp
            vm = np.maximum(S2 - S1 * mu, 0.0) / (spp * (spp - 1.0)) if spp > 1 else np.full_like(mu, np.inf)
            gidx = idx.astype(np.int64) + c0
            mean[gidx], var[gidx] = mu, vm
    finally:
        bar.close()
    H, W = height, width
    return (mean.reshape(H, W, 3).astype(np.float32), var.reshape(H, W, 3).astype(np.float32), mask.reshape(H, W))


def render_estimator(scene, effect, *, width: int, height: int, spp: int, seed: int, estimator, rays_per_sample: int,
                     needs_direct: bool = False, cache: bool = True, cache_dir=None, progress: bool = True,
                     batch_rays: int | None = None) -> Reference:
    """The reference image of ``effect`` from ``estimator`` (module docstring): a
    :class:`~ldbench.references.render.Reference` with mean, variance of the mean and mask; cached."""
    effect.check_scene(scene)
    for what, v in (("width", width), ("height", height), ("spp", spp)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise LdbenchError(f"reference {what} must be a positive integer, got {v!r}")
    width, height, spp, seed = int(width), int(height), int(spp), int(seed)
    variant = choose_variant()
    batch_rays = int(batch_rays or BATCH_RAYS.get(variant, 1 << 22))
    return cached_render(scene, effect, width, height, spp, spp, seed, variant, cache, cache_dir, rays_per_sample,
                         lambda: _render(scene, effect, width, height, spp, seed, progress, batch_rays, estimator,
                                         needs_direct))
