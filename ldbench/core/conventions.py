"""Ray conventions: the one definition of how secondary rays start, which frame and warps turn uniforms
into directions, which random numbers they use, and how six distances become a VPL's range.

The harness's ray batches (``rays``, ``vpl_range``), the Mitsuba references and the methods' shaders all
follow these rules, so a method and its reference trace the same rays. The GLSL twin is
``ldbench/methods/glsl/common/conventions.glsl`` (``#include "common/conventions.glsl"``); ``tests/test_conventions.py`` evaluates
both on random inputs and checks that they agree. numpy + stdlib only (a foundation module).

**Epsilons** (Mitsuba 3's float32 ``math.RayEpsilon`` and ``math.ShadowEpsilon``): :data:`RAY_EPSILON`,
:data:`SHADOW_EPSILON`. The offset scale at a point x is ε(x) = (1 + max|x|) · RAY_EPSILON
(:func:`offset_scale`), Mitsuba's ``Interaction.offset_p``.

**Origin** of a secondary ray leaving a surface point x (:func:`spawn_origin`): o = x' + ε(x') n, n = the
unit normal of the side the ray leaves from: Mitsuba's ``Interaction.spawn_ray`` (along the geometric
normal, relative epsilon). Callers pass the normal of the side the camera or light sees, so a ray into
that surface meets it at once, the methods' rule. x' = :func:`crease_point` (x): x itself, except within
:data:`CREASE` ε of an edge of its triangle, where x' is moved along the line to the triangle's centroid
until it is CREASE ε from every edge (or reaches the centroid). That is the case of a pixel centre on a
crease, x on the edge where two walls meet: x + ε n lies in the other wall's plane and rays into that wall
escape through it. The move stays in the surface (no offset along n) and touches only points that close to
an edge. (The earlier rule, x − 16 ε d_cam + ε n, also fixed creases but moved every origin up to 17 ε
off its surface, 4 mm on cornell and 23 mm on atrium: a bias; docs/reference/rays.md, "Secondary-ray origin".)
Where no triangle is known (a G-buffer, the LDI gather), x' = x.

**Frame** (:func:`tangent_frame`): the branchless orthonormal basis of Duff et al. (2017),
s = sign(n_z) (+1 at 0), a = −1/(s + n_z), c = n_x n_y a,
t = (1 + s n_x² a, s c, −s n_x), b = (c, s + n_y² a, −n_y). :func:`around` gives the unit direction at
polar angle θ (``cos_t`` = cos θ) and azimuth φ about an axis in that frame:
t sin θ cos φ + b sin θ sin φ + axis cos θ.

**Warps** of two uniforms (u₀, u₁) ∈ [0, 1)², φ = 2π u₁ in every case:

- cosine hemisphere about n (pdf cos θ/π): cos θ = √(1 − u₀) (:func:`cosine_direction`);
- normalized Phong lobe (e+1)/(2π) cos^e α about an axis: cos α = u₀^(1/(e+1)) (:func:`phong_direction`);
- uniform on a sphere (by area) of radius r about c: z = 1 − 2u₀,
  c + r (√(1−z²) cos φ, √(1−z²) sin φ, z)
  (:func:`sphere_point`).

**Random numbers.**

- Ray batches (``ldbench.core.effects.rays.build_batch``): numpy's ``Generator(PCG64(SeedSequence([seed,
  stream])))``, ``stream`` = the index of the ray kind in ``("diffuse", "glossy", "shadow", "ao")``; one call
  ``random((N, 2))`` for the N rays in batch order (pixel-major: the ``rays_per_pixel`` rays of a pixel are
  consecutive; pixels in row-major order, row 0 at the top; only pixels whose primary ray hit), column 0 =
  u₀, column 1 = u₁ (:func:`batch_uniforms`). To regenerate a batch independently: take the pixel-centre
  primary hits, repeat each hit pixel ``rays_per_pixel`` times, draw the uniforms this way and apply the
  warp of the kind (diffuse/ao: cosine about n; glossy: Phong about the mirror direction of the camera ray,
  a sample below the surface mirrored about the tangent plane; shadow: sphere point about the light).
- VPL azimuths (``vpl_range``): φ₀ = 2π · :func:`hash01` (texel, seed), where hash01 is the top 24 bits
  of lowbias32(texel + lowbias32(seed)) (:func:`hash32`, Chris Wellons' integer hash) divided by 2²⁴.
- Per-sample streams in shaders (the LDI gather): state = pcg(pixel ^ pcg(seed ^ pcg(sample)))
  (:func:`sample_stream`, :func:`pcg_hash` = the PCG-RXS-M-XS hash of Jarzynski and Olano 2020); each
  uniform is state ← pcg(state), u = (state >> 8) / 2²⁴ (:func:`pcg_uniforms`).
- Mitsuba references: one PCG32 per lane seeded through TEA (``ldbench.references.integrators.rng2``).

**VPL range** (:func:`reduce_range`): each of the six distances t is clamped to the miss range ``cap``
(t ∉ [0, ∞) — a miss, NaN, a negative "no hit" — counts ``cap``), then the mean or the max of the six.
"""
from __future__ import annotations

import math

import numpy as np

from ldbench.core.errors import LdbenchError

RAY_EPSILON = 8.940697e-05     # Mitsuba 3's float32 math.RayEpsilon
SHADOW_EPSILON = 8.940697e-04  # Mitsuba 3's float32 math.ShadowEpsilon
CREASE = 4.0                   # crease_point: ε's from every edge of the triangle
RANGE_MODES = ("mean", "max")


def offset_scale(p, ray_epsilon: float = RAY_EPSILON) -> np.ndarray:
    """ε(p) = (1 + max|p|) · ray_epsilon per point (p: (N, 3) → (N,))."""
    return (1.0 + np.abs(np.asarray(p)).max(-1)) * ray_epsilon


def spawn_origin(x, n, ray_epsilon: float = RAY_EPSILON) -> np.ndarray:
    """o = x + ε(x) n (x, n: (…, 3), n unit): Mitsuba's ``spawn_ray`` offset."""
    x = np.asarray(x, np.float64)
    return x + np.asarray(n, np.float64) * offset_scale(x, ray_epsilon)[..., None]


def crease_point(x, e1, e2, uv, ray_epsilon: float = RAY_EPSILON) -> np.ndarray:
    """x moved towards its triangle's centroid until :data:`CREASE` ε(x) from every edge (module docstring).

    The triangle is (p0, p0 + e1, p0 + e2) with x = p0 + u e1 + v e2, ``uv`` = (u, v) (N, 2) (Mitsuba's
    ``si.uv``, ``si.dp_du``, ``si.dp_dv`` of a mesh without texture coordinates). Points farther from every
    edge, and degenerate triangles, are returned unchanged."""
    x, e1, e2, uv = (np.asarray(a, np.float64) for a in (x, e1, e2, uv))
    b = np.stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]], -1)
    area2 = np.linalg.norm(np.cross(e1, e2), axis=-1)
    lengths = np.stack([np.linalg.norm(e2 - e1, axis=-1), np.linalg.norm(e2, axis=-1), np.linalg.norm(e1, axis=-1)], -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = area2[:, None] / lengths                      # heights over the edges opposite p0, p1, p2
        delta = CREASE * offset_scale(x, ray_epsilon)[:, None]
        dist = b * h
        lam = np.where(dist < delta, (delta - dist) / ((1.0 / 3.0 - b) * h), 0.0)
        lam = np.where(np.isfinite(lam) & (b < 1.0 / 3.0), lam, np.where(dist < delta, 1.0, 0.0))
    lam = np.clip(lam.max(-1), 0.0, 1.0)
    lam = np.where(area2 > 0, lam, 0.0)
    to_c = (1.0 / 3.0 - uv[:, :1]) * e1 + (1.0 / 3.0 - uv[:, 1:]) * e2
    return np.where((lam > 0)[:, None], x + lam[:, None] * to_c, x)


def tangent_frame(n: np.ndarray):
    """Orthonormal tangents (t, b) of unit vectors n (N, 3) (Duff et al. 2017)."""
    n = np.asarray(n)
    s = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (s + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1 + s * n[:, 0] ** 2 * a, s * b, -s * n[:, 0]], -1)
    bb = np.stack([b, s + n[:, 1] ** 2 * a, -n[:, 1]], -1)
    return t, bb


def around(axis: np.ndarray, cos_t: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Directions at polar cosine ``cos_t`` and azimuth ``phi`` about unit ``axis`` in its tangent frame."""
    t, b = tangent_frame(axis)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t ** 2))
    return (t * (sin_t * np.cos(phi))[:, None] + b * (sin_t * np.sin(phi))[:, None]
            + axis * cos_t[:, None])


def cosine_direction(n: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Cosine-distributed directions about unit n from uniforms u (N, 2)."""
    return around(n, np.sqrt(1.0 - u[:, 0]), 2.0 * np.pi * u[:, 1])


def phong_direction(axis: np.ndarray, exponent: float, u: np.ndarray) -> np.ndarray:
    """Directions from the normalized Phong lobe (e+1)/(2π) cos^e α about unit ``axis``."""
    return around(axis, u[:, 0] ** (1.0 / (exponent + 1.0)), 2.0 * np.pi * u[:, 1])


def sphere_point(center, radius, u: np.ndarray) -> np.ndarray:
    """Points uniform by area on the sphere of ``radius`` about ``center`` (one, or one per point)."""
    z = 1.0 - 2.0 * u[:, 0]
    rr = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    return (np.asarray(center, np.float64)
            + np.asarray(radius, np.float64)[..., None] * np.stack([rr * np.cos(phi), rr * np.sin(phi), z], -1))


def batch_uniforms(seed: int, stream: int, n: int) -> np.ndarray:
    """(n, 2) uniforms of a ray batch: PCG64 seeded with SeedSequence([seed, stream])."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(stream)]))
    return rng.random((int(n), 2))


def _u32(v) -> np.ndarray | np.uint32:
    """Integers (Python or numpy, any sign) modulo 2³² as uint32 (a scalar stays a scalar)."""
    if isinstance(v, (int, np.integer)):
        return np.uint32(int(v) & 0xFFFFFFFF)
    return (np.asarray(v, np.int64) & 0xFFFFFFFF).astype(np.uint32)


def hash32(x) -> np.ndarray:
    """Chris Wellons' ``lowbias32`` integer hash (uint32 → uint32), as in GLSL."""
    x = np.asarray(x, np.uint32).copy()
    with np.errstate(over="ignore"):
        x ^= x >> np.uint32(16)
        x *= np.uint32(0x7FEB352D)
        x ^= x >> np.uint32(15)
        x *= np.uint32(0x846CA68B)
        x ^= x >> np.uint32(16)
    return x


def hash01(texel, seed) -> np.ndarray:
    """A uniform number in [0, 1) per texel (seed: one, or one per texel): the top 24 bits of
    hash32(texel + hash32(seed))."""
    s = hash32(_u32(seed))
    with np.errstate(over="ignore"):
        h = hash32(np.asarray(texel, np.uint32) + s)
    return (h >> np.uint32(8)).astype(np.float64) * (1.0 / (1 << 24))


def pcg_hash(v) -> np.ndarray:
    """The PCG-RXS-M-XS 32-bit hash (uint32 → uint32), as ``pcg_hash`` in GLSL."""
    v = np.asarray(v, np.uint32)
    with np.errstate(over="ignore"):
        s = v * np.uint32(747796405) + np.uint32(2891336453)
        word = ((s >> ((s >> np.uint32(28)) + np.uint32(4))) ^ s) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def sample_stream(pixel, seed, sample) -> np.ndarray:
    """A shader sample's random state: pcg(pixel ^ pcg(seed ^ pcg(sample)))."""
    s = _u32(seed)
    return pcg_hash(np.asarray(pixel, np.uint32) ^ pcg_hash(s ^ pcg_hash(np.asarray(sample, np.uint32))))


def pcg_uniforms(state, k: int) -> np.ndarray:
    """(…, k) uniforms from a stream: state ← pcg(state), u = (state >> 8) / 2²⁴, k times."""
    state = np.asarray(state, np.uint32)
    out = []
    for _ in range(int(k)):
        state = pcg_hash(state)
        out.append((state >> np.uint32(8)).astype(np.float64) * (1.0 / (1 << 24)))
    return np.stack(out, -1)


def reduce_range(t, cap: float, mode: str, per: int = 6) -> np.ndarray:
    """Per-VPL range from ``per`` distances each ((N·per,) → (N,) float32): clamp to ``cap`` (a miss,
    NaN or negative distance counts ``cap``), then the mean or the max."""
    if mode not in RANGE_MODES:
        raise LdbenchError(f"range mode must be one of {', '.join(RANGE_MODES)}, got {mode!r}")
    if not (isinstance(cap, (int, float, np.floating)) and math.isfinite(cap) and cap > 0):
        raise LdbenchError(f"the miss range must be a positive finite number, got {cap!r}")
    t = np.asarray(t, np.float64).reshape(-1, per)
    with np.errstate(invalid="ignore"):
        c = np.where(np.isfinite(t) & (t >= 0), np.minimum(t, cap), cap)
    return (c.mean(1) if mode == "mean" else c.max(1)).astype(np.float32)
