"""Reference of ``soft_shadows`` (:mod:`ldbench.core.effects.soft_shadows`), with Mitsuba 3 on the same triangles
(:func:`ldbench.references.wavefront.render_estimator`).

Per pixel, at the camera's hit x₁: the unshadowed direct light of the scene's (first) spot light leaving
x₁ towards the camera, a₁/π · I · falloff · cos / d² (:func:`ldbench.references.integrators.direct_light` without
its shadow ray), times, per sample, the visibility of a point y uniform by area on the sphere of radius
``light_radius`` around the light's position (z = 1 − 2u₀, φ = 2π u₁): 1 if y is above x₁'s tangent plane
and ``ray_test`` from o = ``spawn_origin`` (x₁ + ε n₁) towards y
(maxt = |y − o|(1 − ShadowEpsilon)) finds nothing, else 0.
"""
from __future__ import annotations

import dataclasses

from . import integrators as _int
from .wavefront import render_estimator


def soft_shadow_sample(mi, dr, mscene, scene, effect, lanes, pixel, sample, seed_key):
    u = _int.rng2(mi, dr, pixel, sample, seed_key)
    z = 1.0 - 2.0 * u.x
    rr = dr.safe_sqrt(1.0 - z * z)
    phi = 2.0 * dr.pi * u.y
    c = mi.Point3f(*[float(x) for x in scene.lights[0].position])
    y = c + float(effect.light_radius) * mi.Vector3f(rr * dr.cos(phi), rr * dr.sin(phi), z)
    o = _int.spawn_origin(mi, dr, lanes["p"], lanes["n"])
    v = y - o
    dist = dr.norm(v)
    w = v / dist
    above = dr.dot(w, lanes["n"]) >= 0.0
    ray = mi.Ray3f(mi.Ray3f(o, w), dist * (1.0 - mi.math.ShadowEpsilon))  # Ray3f(o, d, x) would set the time
    blocked = mscene.ray_test(ray, above)
    return dr.select(above & ~blocked, lanes["direct"], mi.Color3f(0.0))


def render_soft_shadows(scene, effect, *, width, height, spp, seed=0, cache=True, progress=True, **kw):
    """:class:`~ldbench.references.render.Reference` of ``soft_shadows`` (module docstring)."""
    one = dataclasses.replace(scene, lights=list(scene.lights[:1]))
    return render_estimator(one, effect, width=width, height=height, spp=spp, seed=seed,
                            estimator=soft_shadow_sample, rays_per_sample=1, needs_direct=True, cache=cache,
                            progress=progress, **kw)
