"""The exact reference of the ``oit`` effect (:mod:`ldbench.core.effects.oit`): every intersection along each
pixel-centre primary ray, composited front to back. No sampling noise.

:func:`intersections` — for each mesh on its own (a Mitsuba scene holding only that mesh, so a surface
coincident with one of another mesh is found too), the pixel-centre rays are intersected with
``ray_intersect_preliminary`` in one wavefront, then re-launched from just past each hit until every ray
misses:

- the next origin is o + d · (t + δ) with t the hit's distance from the camera, computed in float64 and
  rounded to float32 once (no drift from chained float32 origins), δ = (1 + max|scene|) · 2⁻²⁰ (a few
  float32 ulps of the scene's coordinates: surfaces closer than δ along the ray are merged);
- a hit on the same triangle as the ray's previous hit (a grazing re-hit) is skipped, not recorded;
- the recorded depth is the float64 distance from the camera to the hit triangle's plane along the ray,
  so that coincident copies of a triangle get bitwise equal depths (the effect's tie rule) whatever
  origin found them; Mitsuba decides *which* triangles the ray crosses.

:func:`render_oit` sorts each pixel's hits by (depth, mesh index) — the effect's tie rule — and
composites them with :func:`ldbench.core.effects.oit.composite`'s formula in float64 (vectorised by layer
rank). ``max_layers`` > 0 composites only the first n (the reference of yang2010's layer cap).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ldbench.core.effects import Effect
from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.errors import LdbenchError

from . import integrators as _int
from .render import Reference
from .variant import choose_variant, variant_active

# Lazy: drjit and mitsuba are imported in the functions that trace, after choose_variant()
# (ldbench.references.variant) has set up libLLVM, which must come before their first import, and chosen the variant;
# importing this package (the harness, every worker) stays without them.

MAX_LAUNCHES = 100_000  # per mesh: a bound on the depth complexity (never reached by a sane scene)


@dataclass
class Intersections:
    """Every hit of the pixel-centre rays: ``pixel`` (row-major, row 0 at the top), ``depth`` (float64
    distance from the camera), ``mesh`` (index in ``scene.meshes``), unsorted; image ``width × height``."""

    pixel: np.ndarray
    depth: np.ndarray
    mesh: np.ndarray
    width: int
    height: int
    variant: str
    launches: int

    def counts(self) -> np.ndarray:
        """Depth complexity per pixel (H, W): the number of surfaces each pixel-centre ray crosses."""
        n = self.width * self.height
        return np.bincount(self.pixel, minlength=n).reshape(self.height, self.width)


def _mesh_scene(mi, m):
    mesh = mi.Mesh("m", len(m.vertices), len(m.faces))
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(m.vertices, np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(m.faces, np.uint32).ravel())
    params.update()
    return mi.load_dict({"type": "scene", "m": mesh})


def intersections(scene, width: int, height: int) -> Intersections:
    """All surfaces along every pixel-centre ray (see the module docstring)."""
    import drjit as dr

    o32, d32 = _int.primary_rays(scene, width, height)
    o64, d64 = o32.astype(np.float64), d32.astype(np.float64)
    lo, hi = scene.bounds()
    scale = 1.0 + max(float(np.abs(lo).max()), float(np.abs(hi).max()), float(np.abs(o64[0]).max()))
    delta = scale * 2.0 ** -20
    variant = choose_variant()
    out_pix, out_t, out_m = [], [], []
    launches = 0
    with variant_active(variant) as mi:
        for k, m in enumerate(scene.meshes):
            if len(m.faces) == 0:
                continue
            try:
                ms = _mesh_scene(mi, m)
            except Exception as e:
                raise LdbenchError(f"Mitsuba could not build mesh {m.name!r} of {scene.name!r}: "
                                   f"{str(e).splitlines()[0]}") from None
            v = m.vertices.astype(np.float64)
            f = m.faces
            n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # plane normals, unnormalised
            h = np.einsum("ij,ij->i", n, v[f[:, 0]])  # plane: n·x = h
            idx = np.arange(width * height)
            s = np.zeros(len(idx))  # distance from the camera to each active ray's current origin
            last = np.full(len(idx), -1, np.int64)  # previous triangle hit by each active ray
            for _ in range(MAX_LAUNCHES):
                if len(idx) == 0:
                    break
                org = (o64[idx] + d64[idx] * s[:, None]).astype(np.float32)
                ray = mi.Ray3f(_int.vec(mi, mi.Point3f, org), _int.vec(mi, mi.Vector3f, d32[idx]))
                pi = ms.ray_intersect_preliminary(ray)
                valid, t_loc, prim = pi.is_valid(), mi.Float(pi.t), mi.UInt32(pi.prim_index)
                dr.eval(valid, t_loc, prim)
                launches += 1
                hit = _int.np1(valid).astype(bool)
                idx, s, last = idx[hit], s[hit], last[hit]
                t_loc = _int.np1(t_loc)[hit].astype(np.float64)
                prim = _int.np1(prim)[hit].astype(np.int64)
                # exact depth: distance from the camera along d to the triangle's plane (float64)
                den = np.einsum("ij,ij->i", n[prim], d64[idx])
                num = h[prim] - np.einsum("ij,ij->i", n[prim], o64[idx])
                t_ray = s + t_loc
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = np.where(np.abs(den) > 1e-12 * np.linalg.norm(n[prim], axis=1), num / den, t_ray)
                t = np.where(np.abs(t - t_ray) <= 1e-3 * scale, t, t_ray)  # guard against a degenerate plane
                new = prim != last
                out_pix.append(idx[new])
                out_t.append(t[new])
                out_m.append(np.full(int(new.sum()), k, np.int32))
                s = np.maximum(np.maximum(t, t_ray) + delta, s + delta)
                last = prim
            else:
                raise LdbenchError(f"the oit reference of {scene.name!r} met more than {MAX_LAUNCHES} surfaces "
                                   f"along one ray of mesh {m.name!r}")
    cat = (lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dt))  # noqa: E731
    return Intersections(cat(out_pix, np.int64), cat(out_t, np.float64), cat(out_m, np.int32), width, height,
                         variant, launches)


def composite_hits(scene, hits: Intersections, max_layers: int = 0, background=None) -> np.ndarray:
    """(H, W, 3) float64: each pixel's hits sorted by (depth, mesh) and composited front to back
    (``max_layers`` > 0: the first n only) over the background."""
    bg = np.asarray(BACKGROUND if background is None else background, np.float64)
    npix = hits.width * hits.height
    o = np.lexsort((hits.mesh, hits.depth, hits.pixel))  # by pixel, then the tie rule
    pix, mesh = hits.pixel[o], hits.mesh[o]
    first = np.searchsorted(pix, pix, side="left")
    rank = np.arange(len(pix)) - first
    albedo = np.array([m.albedo for m in scene.meshes], np.float32).astype(np.float64)
    alpha = np.array([m.opacity for m in scene.meshes], np.float32).astype(np.float64)
    C = np.zeros((npix, 3))
    T = np.ones(npix)
    by_rank = np.argsort(rank, kind="stable")
    bounds = np.searchsorted(rank[by_rank], np.arange(rank.max() + 2 if len(rank) else 1))
    layers = len(bounds) - 1 if max_layers <= 0 else min(max_layers, len(bounds) - 1)
    for r in range(layers):
        sel = by_rank[bounds[r]:bounds[r + 1]]  # one fragment per pixel: rank r
        p, mm = pix[sel], mesh[sel]
        C[p] += (T[p] * alpha[mm])[:, None] * albedo[mm]
        T[p] *= 1.0 - alpha[mm]
    C += T[:, None] * bg
    return C.reshape(hits.height, hits.width, 3)


def render_oit(scene, width: int, height: int, max_layers: int = 0) -> Reference:
    """The ``oit`` reference image: :class:`~ldbench.references.render.Reference` with zero variance; ``mask`` =
    pixels whose ray crosses at least one surface; ``meta`` has ``fragments``, ``layers_max``,
    ``layers_mean`` (over covered pixels), ``launches``, ``seconds``, ``variant``."""
    for what, val in (("width", width), ("height", height)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 1:
            raise LdbenchError(f"reference {what} must be a positive integer, got {val!r}")
    t0 = time.perf_counter()
    try:
        hits = intersections(scene, int(width), int(height))
    except (RuntimeError, MemoryError) as e:
        msg = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise LdbenchError(f"Mitsuba failed the oit reference of {scene.name!r}: {msg}") from e
    img = composite_hits(scene, hits, max_layers).astype(np.float32)
    counts = hits.counts()
    mask = counts > 0
    seconds = time.perf_counter() - t0

    meta = {"variant": hits.variant, "spp": 1, "spp_requested": 1, "seconds": seconds, "key": None,
            "cached": False, "effect": Effect("oit").key(), "width": int(width), "height": int(height),
            "scene": scene.name, "scene_hash": scene.content_hash(), "exact": True,
            "fragments": int(len(hits.pixel)), "layers_max": int(counts.max()),
            "layers_mean": float(counts[mask].mean()) if mask.any() else 0.0, "launches": hits.launches,
            "max_layers": int(max_layers)}
    if not math.isfinite(float(img.sum())):
        raise LdbenchError(f"the oit reference of {scene.name!r} produced non-finite values")
    return Reference(img, np.zeros_like(img), mask, meta)
