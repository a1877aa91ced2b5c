"""The ground truth of the ``vpl_range`` effect (:mod:`ldbench.core.effects.vpl_range`), with Mitsuba 3: the
reflective shadow map's exact hits that give the VPLs (:func:`rsm_hits`, read by
:func:`ldbench.core.effects.vpl_range.make_vpls`) and the exact ranges (:func:`exact_ranges`,
``trace_oracle`` of the ``rays`` effect on the same rays, reduced as the effect defines).

The RSM is Mitsuba's exact first hit of ``rsm²`` rays from the light through the texel centres of
:func:`ldbench.core.effects.vpl_range.rsm_camera` (the same view the method rasterizes for ``indirect``):
position, geometric normal flipped to face the light, albedo.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ldbench.core.effects import vpl_range
from ldbench.core.effects.vpl_range import VplRangeReference, reduce_ranges, rsm_camera
from ldbench.core.errors import LdbenchError

from . import integrators as _int
from .rays import epsilons, trace_oracle
from .variant import choose_variant, variant_active

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them.


def rsm_hits(scene, R: int) -> dict:
    """Mitsuba's first hits of the RSM rays: ``mask``, ``position``, ``spawn`` (its crease point, where the
    VPL's rays start before their offset), ``normal`` (facing the light),
    ``albedo``, ``direction`` (light → texel centre), each (R², ·), row-major, row 0 at the top."""
    if not scene.lights:
        raise LdbenchError(f"scene {scene.name!r} has no light: no reflective shadow map")
    cam = rsm_camera(scene.lights[0])
    o, d = cam.primary_rays(R, R)
    import drjit as dr

    with variant_active(choose_variant()) as mi:
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
    """:func:`ldbench.core.effects.vpl_range.make_vpls` from Mitsuba's exact RSM hits (what the harness hands in)."""
    return vpl_range.make_vpls(scene, params, seed, SimpleNamespace(rsm_hits=rsm_hits, epsilons=epsilons))


def exact_ranges(scene, batch):
    """:class:`~ldbench.core.effects.vpl_range.VplRangeReference`: Mitsuba's distances on the batch's rays
    (``trace_oracle``, timed as for the ``rays`` effect) and the ranges they give."""
    ref = trace_oracle(scene, batch.rays)
    return VplRangeReference(range=reduce_ranges(ref.t, batch.cap, batch.mode), t=ref.t, seconds=ref.seconds,
                             timing=ref.timing, meta={**ref.meta, "vpls": len(batch)})
