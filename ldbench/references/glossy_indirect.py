"""Reference of ``glossy_indirect`` (:mod:`ldbench.core.effects.glossy_indirect`): one glossy bounce of the spot
light's direct light, estimated with Mitsuba 3 on the same triangles (:func:`ldbench.references.wavefront.render_estimator`).

Per sample, at the camera's hit x₁ (normal n₁ facing the camera, albedo a₁, view direction d):
ω from the normalized Phong lobe (e + 1)/(2π) cos^e α about r = d − 2(d·n₁)n₁ (``mi.warp`` is not used:
cos α = u₀^(1/(e+1)), φ = 2π u₁ in the frame of r); ω·n₁ ≤ 0 gives 0, otherwise the ray from
``spawn_origin`` (x₁ + ε n₁) along ω finds x₂ and the sample is a₁ (e + 2)/(e + 1) (ω·n₁) ·
L_direct(x₂ → x₁)
(:func:`ldbench.references.integrators.direct_light`: the spot light, two-sided diffuse at x₂, hard shadow);
an escaping ray gives 0.
"""
from __future__ import annotations

from . import integrators as _int
from .wavefront import render_estimator


def glossy_sample(mi, dr, mscene, scene, effect, lanes, pixel, sample, seed_key):
    e = float(effect.exponent)
    u = _int.rng2(mi, dr, pixel, sample, seed_key)
    n, d = lanes["n"], lanes["d"]
    r = d - 2.0 * dr.dot(d, n) * n
    cos_a = dr.power(u.x, 1.0 / (e + 1.0))
    sin_a = dr.safe_sqrt(1.0 - cos_a * cos_a)
    phi = 2.0 * dr.pi * u.y
    w = mi.Frame3f(r).to_world(mi.Vector3f(sin_a * dr.cos(phi), sin_a * dr.sin(phi), cos_a))
    c = dr.dot(w, n)
    active = c > 0.0
    si2 = mscene.ray_intersect(mi.Ray3f(_int.spawn_origin(mi, dr, lanes["p"], n), w), active)
    hit = active & si2.is_valid()
    L = _int.direct_light(mi, dr, mscene, si2, hit)
    return dr.select(hit, lanes["albedo"] * ((e + 2.0) / (e + 1.0)) * c * L, mi.Color3f(0.0))


def render_glossy_indirect(scene, effect, *, width, height, spp, seed=0, cache=True, progress=True, **kw):
    """:class:`~ldbench.references.render.Reference` of ``glossy_indirect`` (module docstring)."""
    return render_estimator(scene, effect, width=width, height=height, spp=spp, seed=seed, estimator=glossy_sample,
                            rays_per_sample=1 + len(scene.lights), cache=cache, progress=progress, **kw)
