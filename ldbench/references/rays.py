"""The exact ray oracle of the ``rays`` effect (:mod:`ldbench.core.effects.rays`): Mitsuba 3 on the same triangles.

:func:`ldbench.core.effects.rays.make_batch` builds the ray batch from Mitsuba's own primary hits
(:func:`ldbench.references.render.primary_hits`) and :func:`epsilons`; :func:`trace_oracle` answers it in one
wavefront with ``ray_intersect_preliminary`` (closest hit, ``maxt`` = the ray's t_max) or ``ray_test``
(shadow rays) and times itself:

- CUDA: the sum of Dr.Jit's kernel device times (``dr.kernel_history()``, ``execution_time``) of a second,
  identical launch, so code generation and compilation of the first launch are excluded;
- LLVM (CPU): wall clock of the second launch around ``dr.eval`` + ``dr.sync_thread`` (timing "wall").
"""
from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from ldbench.core.effects import rays
from ldbench.core.effects.rays import RaysReference
from ldbench.core.errors import LdbenchError

from . import integrators as _int
from .render import primary_hits
from .variant import choose_variant, variant_active

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them.


def epsilons():
    """Mitsuba's (RayEpsilon, ShadowEpsilon) of the variant in use: ``ldbench.core.conventions``' values for the
    float32 variants."""
    with variant_active(choose_variant()) as mi:
        return float(mi.math.RayEpsilon), float(mi.math.ShadowEpsilon)


def make_batch(scene, width: int, height: int, params, seed: int):
    """:func:`ldbench.core.effects.rays.make_batch` from Mitsuba's exact primary hits (what the harness hands in)."""
    return rays.make_batch(scene, width, height, params, seed, SimpleNamespace(primary_hits=primary_hits,
                                                                              epsilons=epsilons))


def trace_oracle(scene, batch):
    """:class:`~ldbench.core.effects.rays.RaysReference`: exact answers and the oracle's time on ``batch``."""
    import drjit as dr

    variant = choose_variant()
    with variant_active(variant) as mi:
        mscene = _int.build_scene(scene, with_lights=False)
        o = _int.vec(mi, mi.Point3f, batch.origin)
        d = _int.vec(mi, mi.Vector3f, batch.direction)
        tmax = mi.Float(np.ascontiguousarray(batch.tmax, np.float32))
        dr.eval(o, d, tmax)

        def launch():
            ray = mi.Ray3f(mi.Ray3f(o, d), tmax)  # (o, d, x) would set the ray's *time*, not maxt
            if batch.occlusion:
                out = dr.select(mscene.ray_test(ray), 0.0, math.inf)
            else:
                pi = mscene.ray_intersect_preliminary(ray)
                out = dr.select(pi.is_valid(), pi.t, math.inf)
            out = mi.Float(out)
            dr.eval(out)
            dr.sync_thread()
            return out

        cuda = variant.startswith("cuda")
        try:
            launch()  # compile (and warm the kernel cache)
            flag = dr.flag(dr.JitFlag.KernelHistory)
            dr.set_flag(dr.JitFlag.KernelHistory, True)
            dr.kernel_history()  # clears
            t0 = time.perf_counter()
            out = launch()
            wall = time.perf_counter() - t0
            hist = dr.kernel_history()
            dr.set_flag(dr.JitFlag.KernelHistory, flag)
        except (RuntimeError, MemoryError) as e:
            msg = (str(e).strip().splitlines() or [type(e).__name__])[0]
            raise LdbenchError(f"Mitsuba ({variant}) failed tracing {len(batch)} rays on {scene.name!r}: {msg}") from e
        t = _int.np1(out).astype(np.float32)
        if cuda:
            kernels = [k for k in hist if str(k.get("type", "")).endswith("JIT")]
            seconds, timing = sum(float(k.get("execution_time", 0.0)) for k in kernels) * 1e-3, "kernel"
        else:
            seconds, timing = wall, "wall"
    return RaysReference(t=t, mask=batch.primary_mask, seconds=seconds, timing=timing,
                         meta={"variant": variant, "rays": len(t), "spp": None, "key": None,
                               "kernels": len(hist)})
