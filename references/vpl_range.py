"""The harness side of the ``vpl_range`` effect (:mod:`harness.effects.vpl_range`), with Mitsuba 3: the
reflective shadow map that gives the VPLs (:func:`make_vpls`) and the exact ranges (:func:`exact_ranges`,
``trace_oracle`` of the ``rays`` effect on the same rays, reduced as the effect defines).

The RSM is Mitsuba's exact first hit of ``rsm²`` rays from the light through the texel centres of
:func:`harness.effects.vpl_range.rsm_camera` (the same view the method rasterizes for ``indirect``):
position, geometric normal flipped to face the light, albedo.
"""
from __future__ import annotations

import numpy as np

from harness.errors import LdbenchError

from . import integrators as _int
from .rays import _epsilons, trace_oracle
from .render import _variant_active
from .variant import choose_variant


def rsm_hits(scene, R: int) -> dict:
    """Mitsuba's first hits of the RSM rays: ``mask``, ``position``, ``spawn`` (its crease point, where the
    VPL's rays start before their offset), ``normal`` (facing the light),
    ``albedo``, ``direction`` (light → texel centre), each (R², ·), row-major, row 0 at the top."""
    from harness.effects.vpl_range import rsm_camera

    if not scene.lights:
        raise LdbenchError(f"scene {scene.name!r} has no light: no reflective shadow map")
    cam = rsm_camera(scene.lights[0])
    o, d = cam.primary_rays(R, R)
    import drjit as dr

    with _variant_active(choose_variant()) as mi:
        mscene = _int.build_scene(scene, with_lights=False)
        ray, si = _int.trace_primary(mi, dr, mscene, np.asarray(o, np.float32), np.asarray(d, np.float32))
        valid = si.is_valid()
        n = _int.facing_normal(dr, si, ray.d)
        alb = si.bsdf().eval_diffuse_reflectance(si, valid)
        dr.eval(valid, si.p, n, alb)
        m = _int.np1(valid).astype(bool)
        return {"mask": m, "position": _int.np3(si.p), "spawn": _int.spawn_points(si), "normal": _int.np3(n),
                "albedo": _int.np3(mi.Color3f(alb)), "direction": np.asarray(d, np.float64)}


def make_vpls(scene, params, seed: int):
    """The :class:`~harness.effects.vpl_range.VplBatch` of ``params`` (an ``rsm``² RSM, six rays per VPL)."""
    from harness.effects.rays import RayBatch
    from harness.effects.vpl_range import (MIN_COS, RAYS_PER_VPL, VplBatch, ray_origins, texel_solid_angle,
                                           vpl_directions)

    R = int(params.rsm)
    light = scene.lights[0] if scene.lights else None
    hits = rsm_hits(scene, R)
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
    ray_eps, _ = _epsilons()
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


def exact_ranges(scene, batch):
    """:class:`~harness.effects.vpl_range.VplRangeReference`: Mitsuba's distances on the batch's rays
    (``trace_oracle``, timed as for the ``rays`` effect) and the ranges they give."""
    from harness.effects.vpl_range import VplRangeReference, reduce_ranges

    ref = trace_oracle(scene, batch.rays)
    return VplRangeReference(range=reduce_ranges(ref.t, batch.cap, batch.mode), t=ref.t, seconds=ref.seconds,
                             timing=ref.timing, meta={**ref.meta, "vpls": len(batch)})
