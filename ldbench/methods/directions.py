"""Deterministic direction sets: the recursive zonal equal-area partition of the sphere (EQSP).

aalund2015 §3.2 places one layered depth map (LDM) per direction and takes the directions as the
centres of the regions of Leopardi's *recursive zonal equal-area partition* [Leo06] (the
``eq_point_set`` / ``eq_regions`` functions of the EQSP Matlab toolbox). This module implements that
partition for S² exactly as EQSP does, and the antipodally symmetric variant the LDM methods use.

EQSP for S² with M regions (:func:`eq_zones`, :func:`eq_point_set`), following the toolbox step by step:

1. every region has the area ``A = 4π/M``; the two polar caps are regions with colatitude
   ``θ_c = 2·asin(1/√M)`` (cap area ``2π(1 − cos θ_c) = A``);
2. the ideal collar angle is ``√A``; the number of collars between the caps is
   ``max(1, round((π − 2θ_c)/√A))``; each collar of the fitting angle ``(π − 2θ_c)/n`` holds the ideal
   (real) number of regions = its area / A;
3. the ideal counts are rounded to integers carrying the rounding error forward ("round_to_naturals"),
   so that they still sum to M;
4. the collar boundaries are moved so that each zone holds exactly its integer count of regions:
   the colatitude of boundary k is that of a cap of area (1 + regions in collars 1..k)·A;
5. each collar is split into its n regions by meridians; region centres are at the mid-colatitude of the
   collar and the mid-longitude of the sector, and successive collars are rotated by EQSP's
   ``circle_offset`` (without the optional "extra twist").

Matlab's ``round`` (halves away from zero) is used, not Python's banker's rounding. The pole is +z in
EQSP; :func:`eq_point_set` returns that convention, the LDM sets below put the pole on +y (the scene's up).

LDM axes (:func:`ldm_axes`). One LDM along axis v answers rays in both directions ±v (aalund2015 §3.1),
so N maps must be N *axes* whose 2N signed directions {±v_i} cover the sphere evenly. The paper culls
"half of the samples in the bottom ring" of an EQSP set because they are parallel to samples on the
other side. We make that exact: the same zonal construction (steps 1–5) is applied to the *upper
hemisphere* alone, with N regions of area 2π/N: a polar cap of colatitude ``acos(1 − 1/N)``, collars
whose last boundary is the equator (colatitude π/2) instead of the south cap. The axes are the region
centres. Then {±v_i} are the centres of a 2N-region equal-area partition of the whole sphere (the
hemisphere's regions and their antipodal images), symmetric under x → −x, and for any normal n exactly
one of ±v_i lies in its hemisphere (unless n ⟂ v_i), so every surface point gets N directions.

Quadrature (aalund2015 eq. 2): with N equal-area directions in a hemisphere,
(1/π)∫ f cos θ dω ≈ (2/N) Σ f(ω_i) cos θ_i; :func:`hemisphere_weights_check` gives the estimator's
value for f = 1 (exactly 1 for the ideal partition).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

# Heavy: scipy.spatial is imported by nearest_axis_table() alone, the one function that needs it.


def _mround(x: float) -> int:
    """Matlab ``round``: halves away from zero."""
    return int(math.floor(abs(x) + 0.5)) * (1 if x >= 0 else -1)


def _cap_area(colat: float) -> float:
    """Area of a spherical cap of colatitude ``colat`` on S²."""
    return 2.0 * math.pi * (1.0 - math.cos(colat))


def _cap_colat(area: float) -> float:
    """Colatitude of the cap of the given area on S² (EQSP ``sradius_of_cap``)."""
    return 2.0 * math.asin(min(1.0, math.sqrt(area / (4.0 * math.pi))))


def _circle_offset(n_top: int, n_bot: int) -> float:
    """EQSP ``circle_offset`` without extra twist: rotation (in turns) of the next collar."""
    return (1.0 / n_bot - 1.0 / n_top) / 2.0 + math.gcd(n_top, n_bot) / (2.0 * n_top * n_bot)


@dataclass(frozen=True)
class Zone:
    """One zone of a zonal partition: colatitudes [top, bottom], ``count`` regions, longitude offset.

    Region k (0-based) of the zone spans longitudes [offset + k·2π/count, offset + (k+1)·2π/count];
    its centre is at colatitude (top + bottom)/2 and the sector's mid-longitude.
    """

    top: float
    bottom: float
    count: int
    offset: float  # radians

    @property
    def area(self) -> float:
        """Area of the whole zone."""
        return 2.0 * math.pi * (math.cos(self.top) - math.cos(self.bottom))

    @property
    def region_area(self) -> float:
        return self.area / self.count


def _zonal(n_regions: int, domain_colat: float) -> list[Zone]:
    """EQSP zonal partition of the cap of colatitude ``domain_colat`` (π = sphere, π/2 = hemisphere)
    into ``n_regions`` equal-area regions. For the sphere the last zone is the south polar cap."""
    N = int(n_regions)
    if N < 1:
        raise ValueError("the number of regions must be >= 1")
    sphere = domain_colat >= math.pi - 1e-12
    total = _cap_area(domain_colat)
    A = total / N
    if N == 1:
        return [Zone(0.0, domain_colat, 1, 0.0)]
    if sphere and N == 2:
        return [Zone(0.0, math.pi / 2, 1, 0.0), Zone(math.pi / 2, math.pi, 1, 0.0)]
    c_polar = _cap_colat(A)
    # the span the collars fill: between the two caps (sphere) or between the cap and the equator
    span = (math.pi - 2 * c_polar) if sphere else (domain_colat - c_polar)
    a_ideal = math.sqrt(A)
    n_collars = max(1, _mround(span / a_ideal)) if span > 1e-12 else 0
    ideal = [1.0]
    if n_collars:
        a_fit = span / n_collars
        for k in range(1, n_collars + 1):
            ideal.append((_cap_area(c_polar + k * a_fit) - _cap_area(c_polar + (k - 1) * a_fit)) / A)
    if sphere:
        ideal.append(1.0)
    # round_to_naturals
    counts, disc = [], 0.0
    for r in ideal:
        n = _mround(r + disc)
        disc += r - n
        counts.append(n)
    if sum(counts) != N:  # cannot happen for the carried rounding; kept as a guard
        raise AssertionError(f"EQSP rounding gave {sum(counts)} regions for {N}")
    # cap_colats: boundaries where the cap holds exactly the regions above
    colats = [c_polar]
    sub = 1
    for k in range(1, n_collars + 1):
        sub += counts[k]
        colats.append(domain_colat if (not sphere and k == n_collars) else _cap_colat(min(sub * A, total)))
    if sphere:
        colats[-1] = math.pi - c_polar if n_collars else colats[-1]
        colats.append(math.pi)
    zones = [Zone(0.0, c_polar, 1, 0.0)]
    offset = 0.0  # in turns, as EQSP keeps it
    for k in range(1, n_collars + 1):
        n = counts[k]
        if n < 1:
            continue
        zones.append(Zone(colats[k - 1], colats[k], n, 2 * math.pi * offset))
        nxt = counts[k + 1] if k + 1 < len(counts) else 1
        offset += _circle_offset(n, max(nxt, 1))
        offset -= math.floor(offset)
    if sphere:
        zones.append(Zone(colats[-2], math.pi, 1, 0.0))
    return zones


def eq_zones(M: int) -> list[Zone]:
    """EQSP zones of the partition of S² into ``M`` equal-area regions (north cap first)."""
    return _zonal(M, math.pi)


def _centres(zones: list[Zone]) -> np.ndarray:
    """Region centres (colatitude, longitude) → unit vectors with the pole on +z."""
    out = []
    for z in zones:
        if z.top == 0.0 and z.count == 1:
            out.append((0.0, 0.0))  # north cap: the pole
            continue
        if z.bottom >= math.pi - 1e-12 and z.count == 1:
            out.append((math.pi, 0.0))  # south cap
            continue
        colat = 0.5 * (z.top + z.bottom)
        for k in range(z.count):
            lon = (z.offset + (k + 0.5) * 2 * math.pi / z.count) % (2 * math.pi)
            out.append((colat, lon))
    c = np.array(out, np.float64)
    s = np.sin(c[:, 0])
    return np.stack([s * np.cos(c[:, 1]), s * np.sin(c[:, 1]), np.cos(c[:, 0])], axis=1)


def eq_point_set(M: int) -> np.ndarray:
    """Centres of the EQSP partition of S² into ``M`` regions: (M, 3) unit vectors, pole = +z."""
    return _centres(eq_zones(M))


def hemisphere_zones(N: int) -> list[Zone]:
    """The zonal equal-area partition of the upper hemisphere (pole +z) into ``N`` regions."""
    return _zonal(N, math.pi / 2)


def _z_to_y(v: np.ndarray) -> np.ndarray:
    """Rotate the pole from +z to +y: −90° about x, (x, y, z) → (x, z, −y) (a proper rotation)."""
    return np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)


@lru_cache(maxsize=64)
def _ldm_axes_cached(N: int) -> np.ndarray:
    v = _z_to_y(_centres(hemisphere_zones(N)))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v.setflags(write=False)
    return v


def ldm_axes(N: int) -> np.ndarray:
    """N LDM axes (N, 3), float64 unit vectors, pole on +y, all in the upper hemisphere (y ≥ 0).

    {±v_i} is an antipodally symmetric 2N-region equal-area partition's centre set (module docstring).
    """
    if int(N) != N or N < 1:
        raise ValueError(f"number of LDM directions must be a positive integer, got {N!r}")
    return np.array(_ldm_axes_cached(int(N)))


def signed_directions(axes: np.ndarray) -> np.ndarray:
    """The 2N signed directions {+v_i} ∪ {−v_i} of a set of axes."""
    return np.concatenate([axes, -axes])


def hemisphere_weights_check(axes: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """For each normal, the eq. (2) estimator of (1/π)∫ cos θ dω = 1 using the axes: (2/N) Σ |n·v_i|.

    (For each axis, the signed direction in the hemisphere of n contributes cos θ = |n·v|.)
    """
    axes = np.asarray(axes, np.float64)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    return 2.0 / len(axes) * np.abs(n @ axes.T).sum(axis=1)


def orthonormal_basis(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (u, w) with (u, w, v) right-handed orthonormal, for each row of ``v`` (N, 3)."""
    v = np.asarray(v, np.float64).reshape(-1, 3)
    # helper axis: the world axis least aligned with v (deterministic, no degeneracy)
    helper = np.zeros_like(v)
    helper[np.arange(len(v)), np.argmin(np.abs(v), axis=1)] = 1.0
    u = np.cross(helper, v)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(v, u)
    return u, w


# --------------------------------------------------------------------------------------------------
# Cube-sampled directions (niessner2010 §3.1)
#
# Each face of the unit cube is split into k × k equal squares; the normalized square centres are the
# n = 6k² directions. Face a (0, 1, 2 = x, y, z) with sign s has in-face coordinates (p, q) = the
# components (a + 1) mod 3 and (a + 2) mod 3 of d / |d_a|, both in [−1, 1]; square (i, j) holds
# p ∈ [2i/k − 1, 2(i + 1)/k − 1), q likewise with j. The set is antipodally symmetric: square (i, j) of
# face −a is minus square (i, j) of face +a, so one orthographic LDI can answer both (``half``).
#
# Lookup (:func:`cube_cell`, and the same rule in ldbench/methods/ldi/ldi_trace.glsl): the major axis a is the
# first of x, y, z whose |component| is largest (x wins ties with y and z, y wins ties with z), s its
# sign, and the square that contains d. This is the cell whose centre is (nearly) the closest
# direction, found in O(1): the reason the paper samples a cube.


def _quaternion_matrix(q) -> np.ndarray:
    x, y, z, w = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


#: A fixed rotation of the cube (cube frame → world, quaternion x, y, z, w) that keeps every direction of
#: k = 4, 5, 8 at least 0.72° from the planes x = 0, y = 0, z = 0 (the best of 4000 random rotations;
#: scipy's Rotation.random(4000, random_state=1)[277]). Unrotated, the cells of odd k whose centres have
#: p = 0 or q = 0 lie in those planes: an orthographic LDI along them sees axis-aligned walls edge-on.
CUBE_ROTATION = _quaternion_matrix((-0.3927397, 0.62511151, -0.34333111, 0.58061595))


def cube_directions(k: int, half: bool = False, rotation=None) -> np.ndarray:
    """The cube-sampled directions, (6k², 3) float64 unit vectors, or (3k², 3) with ``half``.

    Order: faces +x, −x, +y, −y, +z, −z (``half``: +x, +y, +z), then i, then j (see the comment above).
    ``rotation`` (3×3, cube frame → world, e.g. :data:`CUBE_ROTATION`) rotates the whole set.
    """
    if int(k) != k or k < 1:
        raise ValueError(f"cube sampling needs k >= 1 squares per face edge, got {k!r}")
    k = int(k)
    c = (2.0 * np.arange(k) + 1.0) / k - 1.0
    p, q = (g.reshape(-1) for g in np.meshgrid(c, c, indexing="ij"))
    out = []
    for a in range(3):
        v = np.zeros((k * k, 3))
        v[:, a], v[:, (a + 1) % 3], v[:, (a + 2) % 3] = 1.0, p, q
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        out += [v] if half else [v, -v]
    d = np.concatenate(out)
    return d if rotation is None else d @ np.asarray(rotation, np.float64).T


def cube_k(n: int) -> int:
    """k with 6k² = n (the paper's LDI counts 96, 150, 384 are k = 4, 5, 8); ValueError otherwise."""
    k = int(round(math.sqrt(max(int(n), 0) / 6.0)))
    if k < 1 or 6 * k * k != int(n):
        lo = max(1, int(math.floor(math.sqrt(max(int(n), 0) / 6.0))))
        raise ValueError(f"{n} is not 6k^2 (nearest: {6 * lo * lo}, {6 * (lo + 1) ** 2})")
    return k


def cube_cell(d: np.ndarray, k: int, half: bool = False, rotation=None) -> tuple[np.ndarray, np.ndarray]:
    """(index into :func:`cube_directions`, sigma) of each direction d (N, 3): the square containing d;
    with ``half``, the square containing sigma·d on a positive face (sigma = ±1). float64 arithmetic.
    ``rotation``: that of the set (d is taken to the cube frame first)."""
    d = np.asarray(d, np.float64).reshape(-1, 3)
    if rotation is not None:
        d = d @ np.asarray(rotation, np.float64)
    ad = np.abs(d)
    a = np.where((ad[:, 0] >= ad[:, 1]) & (ad[:, 0] >= ad[:, 2]), 0, np.where(ad[:, 1] >= ad[:, 2], 1, 2))
    rows = np.arange(len(d))
    da = d[rows, a]
    s = np.where(da >= 0.0, 1.0, -1.0)
    dp = d * s[:, None]
    ma = dp[rows, a]
    ij = []
    for off in (1, 2):
        t = dp[rows, (a + off) % 3] / ma
        ij.append(np.clip(np.floor((t + 1.0) * 0.5 * k), 0, k - 1).astype(np.int64))
    cell = ij[0] * k + ij[1]
    if half:
        return a * k * k + cell, s
    return (2 * a + (s < 0)) * k * k + cell, np.ones(len(d))


def nearest_axis_table(axes: np.ndarray, res: int = 128, slots: int = 4) -> np.ndarray:
    """Candidate nearest axes per cell of a half cube (:func:`cube_cell` with ``half``, k = ``res``):
    (3·res², ``slots``) uint32, unused slots 0xFFFFFFFF. "Nearest" is by |d·v| (a map answers ±v).

    Each cell lists the nearest axis of a 3 × 3 grid of directions over the cell (corners, edge midpoints,
    centre); a lookup takes the best candidate of its cell, so it finds the true nearest axis unless that
    axis's Voronoi cell touches the cube cell without containing one of the 9 samples (a sliver; then the
    second nearest, within a fraction of the axes' spacing). ``ValueError`` when a cell needs more than
    ``slots`` candidates (raise ``res``).
    """
    axes = np.asarray(axes, np.float64).reshape(-1, 3)
    r = int(res)
    t = np.arange(r + 1) / r * 2.0 - 1.0          # cell edges
    m = (t[:-1] + t[1:]) * 0.5                    # cell centres
    grid = [t[:-1], m, t[1:]]
    from scipy.spatial import cKDTree

    tree = cKDTree(np.concatenate([axes, -axes]))  # the nearest of ±v on the unit sphere = largest |d·v|
    out = np.full((3 * r * r, slots), 0xFFFFFFFF, np.uint32)
    for a in range(3):
        best = []
        for gi in grid:
            for gj in grid:
                P, Q = np.meshgrid(gi, gj, indexing="ij")
                d = np.zeros((r * r, 3))
                d[:, a], d[:, (a + 1) % 3], d[:, (a + 2) % 3] = 1.0, P.reshape(-1), Q.reshape(-1)
                d /= np.linalg.norm(d, axis=1, keepdims=True)
                best.append(tree.query(d)[1] % len(axes))
        b = np.sort(np.stack(best, 1), 1)                         # (cells, 9), per cell ascending
        first = np.concatenate([np.ones((len(b), 1), bool), b[:, 1:] != b[:, :-1]], 1)
        count = first.sum(1)
        if count.max() > slots:
            raise ValueError(f"{count.max()} candidate axes in one cell of a {r}² cube face: raise res")
        rank = np.cumsum(first, 1) - 1                            # slot of each first occurrence
        rows, cols = np.nonzero(first)
        out[a * r * r + rows, rank[rows, cols]] = b[rows, cols]
    return out


# --------------------------------------------------------------------------------------------------
# Stacks × slices hemisphere directions (archer2019 §3.1, Fig. 2)


def stacks_slices_shape(n: int) -> tuple[int, int]:
    """(stacks, slices) with stacks · slices = n and stacks the largest divisor ≤ √n (169 → 13 × 13,
    128 → 8 × 16, a prime n → 1 × n)."""
    n = int(n)
    if n < 1:
        raise ValueError(f"number of directions must be >= 1, got {n}")
    stacks = max(d for d in range(1, math.isqrt(n) + 1) if n % d == 0)
    return stacks, n // stacks


def stacks_slices(n: int) -> np.ndarray:
    """n directions (n, 3) on the upper hemisphere (pole +y) in spherical coordinates: ``stacks`` rings of
    polar angle θ_i = (i + ½)·(π/2)/stacks, each with ``slices`` azimuths φ_j = (j + ½)·2π/slices
    (:func:`stacks_slices_shape`); order i-major. The bottom hemisphere is ±v (a ray along −v reads the
    deep image of v backwards). Not equal-area: the rings near the pole are denser."""
    stacks, slices = stacks_slices_shape(n)
    th = (np.arange(stacks) + 0.5) * (0.5 * math.pi / stacks)
    ph = (np.arange(slices) + 0.5) * (2.0 * math.pi / slices)
    T, P = np.meshgrid(th, ph, indexing="ij")
    v = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
    return v
