"""Mitsuba 3 scene construction and the wavefront integrators of the reference effects.

Everything here runs under the Mitsuba variant set by the caller (:func:`ldbench.references.choose_variant`).

Scene (docs/design.md, "Scenes"): one ``mi.Mesh`` per :class:`ldbench.core.scene.Mesh` (the very same float32
triangles, no vertex normals, so Mitsuba's shading normal is the geometric face normal), BSDF
``twosided(diffuse(albedo))``; a spot light is Mitsuba's ``spot`` (``to_world = look_at(position,
target, up)``, ``intensity`` RGB in W/sr, ``cutoff_angle``, ``beam_width``), a point light
(``cutoff_angle = 180``) Mitsuba's ``point``.

Primary rays go through pixel centres (``ldbench.core.scene.Camera.primary_rays``), no pixel filter, and
are intersected with ``Scene.ray_intersect``; the mask is "the primary ray hit something".

Estimators (all samples of a batch in one wavefront; ``x`` = primary hit, ``n`` = geometric normal
flipped to face the camera, ``ω`` cosine-distributed about ``n`` with pdf cos θ/π):

- ``ao``: per sample ``V = 1 − ρ(t)``, ``t`` = distance to the first hit of the ray
  ``o → ω`` (o = :func:`spawn_origin`) with ``maxt = d_max``; ρ = 1 (step) or 1 − (t/d_max)² (quadratic)
  when it hits, V = 1 when it escapes. The pdf cancels cos θ/π, so the pixel value is the sample mean of V.
  Background pixels are 1.
- ``direct``: deterministic: Σ over lights of ``bsdf.eval(x, ω_l)`` (Mitsuba's ``twosided`` diffuse:
  albedo/π · cos θ, zero when the light is behind the side the camera sees) × the emitter's
  ``sample_direction`` weight (Mitsuba's I · falloff / d²) × the hard-shadow visibility test.
- ``indirect``: x₁ → cosine-sampled ω → x₂ = first hit; per sample ``albedo₁ · L_direct(x₂ → x₁)``
  where L_direct is the ``direct`` term above evaluated at x₂ with outgoing direction towards x₁
  (so n₂ is the normal facing x₁). Escaping samples give 0; background pixels are 0.

Secondary rays start at :func:`spawn_origin` (:func:`ldbench.core.conventions.spawn_origin`): ε along the
facing normal, Mitsuba's own ``(1 + max|p|) · RayEpsilon`` (as in ``Interaction.spawn_ray``), from the
hit's crease point (:func:`spawn_points`: the hit itself unless within a few ε of its triangle's edges).
Random numbers: one PCG32 stream per (pixel, sample index, seed), seeded through TEA hashing, so results
do not depend on how samples are split into batches.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ldbench.core import conventions as conv
from ldbench.core.errors import LdbenchError

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them.

RENDERABLE = ("ao", "direct", "indirect")


def _mi():
    import drjit as dr
    import mitsuba as mi

    return mi, dr


def _look_at_up(position, target, up) -> list:
    """``up`` unless it is (nearly) parallel to the spot axis; then any perpendicular-safe axis.

    The spot's fall-off is rotationally symmetric, so the choice of ``up`` does not change the light.
    """
    d = np.asarray(target, float) - np.asarray(position, float)
    d /= np.linalg.norm(d)
    u = np.asarray(up, float)
    if np.linalg.norm(np.cross(d, u)) > 1e-6 * max(float(np.linalg.norm(u)), 1e-30):
        return [float(x) for x in u]
    axis = np.eye(3)[int(np.argmin(np.abs(d)))]
    return [float(x) for x in axis]


def emitter_dicts(scene) -> dict:
    """The scene's lights as Mitsuba ``load_dict`` entries."""
    mi, _ = _mi()
    out: dict[str, dict[str, Any]] = {}  # Mitsuba plugin dicts: strings, lists, transforms, numbers
    for i, l in enumerate(scene.lights):
        rgb = {"type": "rgb", "value": [float(x) for x in l.intensity]}
        if l.is_point:
            out[f"light{i}"] = {"type": "point", "position": [float(x) for x in l.position], "intensity": rgb}
        else:
            if np.linalg.norm(np.subtract(l.target, l.position)) < 1e-12:
                raise LdbenchError(f"light {i}: target equals its position")
            tw = mi.ScalarTransform4f().look_at(origin=list(l.position), target=list(l.target),
                                                up=_look_at_up(l.position, l.target, l.up))
            out[f"light{i}"] = {"type": "spot", "to_world": tw, "intensity": rgb,
                                "cutoff_angle": float(l.cutoff_angle), "beam_width": float(l.beam_width)}
    return out


def build_scene(scene, with_lights: bool = True):
    """A ``mi.Scene`` holding the scene's triangles (one ``mi.Mesh`` each) and, optionally, its lights."""
    mi, _ = _mi()
    d = {"type": "scene"}
    for i, m in enumerate(scene.meshes):
        if len(m.faces) == 0:
            continue
        props = mi.Properties()
        props["bsdf"] = mi.load_dict({
            "type": "twosided",
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(a) for a in m.albedo]}},
        })
        mesh = mi.Mesh(f"mesh{i}", len(m.vertices), len(m.faces), props=props)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(np.ascontiguousarray(m.vertices, np.float32).ravel())
        params["faces"] = mi.UInt32(np.ascontiguousarray(m.faces, np.uint32).ravel())
        params.update()
        d[f"mesh{i}"] = mesh
    if with_lights:
        d.update(emitter_dicts(scene))
    try:
        return mi.load_dict(d)
    except Exception as e:
        raise LdbenchError(f"Mitsuba could not build scene {scene.name!r}: {str(e).splitlines()[0]}")


# ----------------------------------------------------------------------------------------------------
# building blocks


def primary_rays(scene, width: int, height: int):
    """Pixel-centre rays as float32 numpy (origins, dirs), each (H*W, 3), row 0 at the top."""
    o, d = scene.camera.primary_rays(width, height)
    return np.ascontiguousarray(o, np.float32), np.ascontiguousarray(d, np.float32)


def vec(mi, cls, a):
    a = np.ascontiguousarray(a, np.float32)
    return cls(mi.Float(a[:, 0]), mi.Float(a[:, 1]), mi.Float(a[:, 2]))


def np1(x) -> np.ndarray:
    """Dr.Jit 1-D array → numpy (N,)."""
    return np.asarray(x.numpy() if hasattr(x, "numpy") else x).reshape(-1)


def np3(v) -> np.ndarray:
    """Dr.Jit 3-vector (Point3f, Color3f, …) → numpy (N, 3)."""
    return np.stack([np1(v[i]) for i in range(3)], axis=-1)


def spawn_origin(mi, dr, p, n):
    """:func:`ldbench.core.conventions.spawn_origin`: p + n · (1 + max|p|) · RayEpsilon (Mitsuba's spawn offset;
    n already on the ray's side)."""
    mag = (1.0 + dr.max(dr.abs(p))) * mi.math.RayEpsilon
    return p + n * mag


def spawn_points(si) -> np.ndarray:
    """(N, 3) float32 :func:`ldbench.core.conventions.crease_point` of Mitsuba's hits ``si`` (the triangle from
    ``si.uv`` = barycentrics, ``si.dp_du``, ``si.dp_dv`` = its edges: meshes without texture coordinates)."""
    x = np3(si.p).astype(np.float64)
    ok = np.isfinite(x).all(1) & np1(si.is_valid()).astype(bool)
    uv = np.stack([np1(si.uv[0]), np1(si.uv[1])], -1)
    x[ok] = conv.crease_point(x[ok], np3(si.dp_du)[ok], np3(si.dp_dv)[ok], uv[ok])
    return np.ascontiguousarray(x, np.float32)


def rng2(mi, dr, pixel, sample, seed_key):
    """Two uniform floats per lane from a PCG32 seeded by TEA(pixel, seed) and the sample index."""
    k0, _ = mi.sample_tea_32(pixel, seed_key, 8)
    state = mi.sample_tea_64(k0, sample, 8)
    rng = mi.PCG32(dr.width(pixel))
    rng.seed(initstate=state, initseq=mi.UInt64(sample))
    u0 = rng.next_float32()
    u1 = rng.next_float32()
    return mi.Point2f(u0, u1)


def trace_primary(mi, dr, mscene, o, d):
    """Intersect primary rays (numpy float32 (N,3)); returns (ray, si)."""
    ray = mi.Ray3f(vec(mi, mi.Point3f, o), vec(mi, mi.Vector3f, d))
    si = mscene.ray_intersect(ray)
    return ray, si


def facing_normal(dr, si, ray_d):
    """Geometric normal flipped to face the ray origin (the camera for primary hits)."""
    return dr.select(dr.dot(si.n, ray_d) > 0, -si.n, si.n)


def direct_light(mi, dr, mscene, si, active, shadows: bool = True):
    """Σ_lights bsdf.eval(si, ω_l) · (I · falloff / d²) · V: radiance leaving ``si.p`` towards ``-si.wi``.

    Uses Mitsuba's own emitter ``sample_direction`` (delta lights: exact), ``twosided`` diffuse BSDF
    ``eval`` (albedo/π · cos, zero when the light is on the other side from ``si.wi``) and a shadow ray
    ``si.spawn_ray_to(light)`` tested with ``Scene.ray_test`` (V = 1 without ``shadows``).
    """
    ctx = mi.BSDFContext()
    bsdf = si.bsdf()
    total = mi.Color3f(0.0)
    for em in mscene.emitters():
        ds, spec = em.sample_direction(si, mi.Point2f(0.5, 0.5), active)
        f = bsdf.eval(ctx, si, si.to_local(ds.d), active)
        occluded = mscene.ray_test(si.spawn_ray_to(ds.p), active) if shadows else mi.Bool(False)
        ok = active & ~occluded & (ds.pdf > 0)
        total += dr.select(ok, mi.Color3f(f) * mi.Color3f(spec), 0.0)
    return total


def sample_values(mi, dr, mscene, effect, p, n, albedo, lane_pixel, lane_sample, seed_key):
    """One Monte Carlo sample per lane (ao → Float, indirect → Color3f).

    ``p``, ``n``, ``albedo`` are per-lane primary-hit position, camera-facing geometric normal and
    albedo (Dr.Jit arrays).
    """
    u = rng2(mi, dr, lane_pixel, lane_sample, seed_key)
    frame = mi.Frame3f(n)
    w = frame.to_world(mi.warp.square_to_cosine_hemisphere(u))
    ray = mi.Ray3f(spawn_origin(mi, dr, p, n), w)
    if effect.name == "ao":
        if math.isinf(effect.d_max):
            return dr.select(mscene.ray_test(ray), 0.0, 1.0)
        d_max = float(effect.d_max)
        ray = mi.Ray3f(ray, mi.Float(d_max))
        if effect.falloff == "step":
            return dr.select(mscene.ray_test(ray), 0.0, 1.0)
        pi = mscene.ray_intersect_preliminary(ray)
        hit = pi.is_valid() & (pi.t < d_max)
        t = dr.select(hit, pi.t, 0.0)
        return dr.select(hit, dr.square(t / d_max), 1.0)
    if effect.name == "indirect":
        si2 = mscene.ray_intersect(ray)
        active = si2.is_valid()
        return mi.Color3f(albedo) * direct_light(mi, dr, mscene, si2, active)
    raise LdbenchError(f"the Mitsuba reference does not render effect {effect.name}")
