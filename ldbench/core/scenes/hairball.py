"""The ``hairball`` scene: dense random tubes, a depth complexity that grows with the triangle count."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.meshio import grid_faces, quad
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import SceneBuilder, SceneParams, part_mesh


@dataclass(frozen=True)
class HairballParams(SceneParams):
    triangles: int = param(20000, "triangle count (whole tubes of 120 triangles, plus the floor)",
                           lo=200, hi=4_000_000)
    seed: int = param(0, "seed of the random walks", lo=0, hi=2**63 - 1)
    opacity: float = param(1.0, "the tubes' α for the oit effect (the floor stays opaque)", lo=0.0, hi=1.0)
    colours: int = param(1, "tube colours: tube i takes colour i mod n, one mesh per colour (1: every tube alike)",
                         lo=1, hi=8)


#: The tubes' albedos, linear RGB: the first is the one-colour hairball's; ``colours = n`` uses the first n.
PALETTE = ((0.72, 0.55, 0.38), (0.20, 0.45, 0.85), (0.85, 0.20, 0.20), (0.25, 0.70, 0.30),
           (0.95, 0.85, 0.25), (0.60, 0.30, 0.75), (0.15, 0.75, 0.80), (0.95, 0.95, 0.95))


class Hairball(SceneBuilder):
    """Dense random tubes in the box [-1, 1]³ (high depth complexity) above a floor.

    Each tube is a thin open cylinder (6 sides, 10 segments of 0.12 m: 120 triangles) swept with
    rotation-minimising frames along a smooth random walk (each step turns by at most 35°, pulled
    towards the centre) that stays inside [-0.95, 0.95]³.
    The number of tubes is round((triangles - 2) / 120) (at least 1); the tube radius shrinks with
    the count (0.6 / √tubes, clamped to [0.004, 0.05] m), so the depth complexity grows like √tubes
    (about 5 layers at 20k triangles, 20 at 260k).
    A 6 m floor quad at y = -1.1 receives the shadow. Deterministic for a given ``seed``.
    ``opacity``: the tubes' α for the ``oit`` effect (the floor stays opaque). ``colours = n``: tube i
    takes :data:`PALETTE` colour i mod n, the tubes of one colour one mesh, meshes in palette order (n = 1:
    one mesh): with one colour and one opacity every order of a pixel's tube fragments composites alike,
    with several the order matters (plain alpha blending in submission order is then wrong).
    Camera: (0, 0.8, 4.2) looking at the origin, vertical fov 45°.
    Light: a spot at (2, 4, 3) aimed at the origin, cutoff 35°, beam 26.25°, 60 W/sr.
    """

    name = "hairball"
    Params = HairballParams

    def build(self, params: HairballParams) -> Scene:
        target, seed, opacity, colours = params.triangles, params.seed, params.opacity, params.colours
        sides, segs = 6, 10
        per_tube = 2 * sides * segs
        ntubes = max(1, round((target - 2) / per_tube))
        radius = float(np.clip(0.6 / math.sqrt(ntubes), 0.004, 0.05))
        rng = np.random.default_rng(seed)
        # Smooth random curves: a walk of `segs` steps of STEP metres whose direction turns by at most
        # MAX_TURN per step (random turn + a pull towards the centre beyond radius 0.5), so the
        # curvature radius (≥ STEP / MAX_TURN ≈ 0.2 m) always exceeds the tube radius: no folded tubes.
        step, max_turn = 0.12, math.radians(35.0)
        pts = np.empty((ntubes, segs + 1, 3))
        pts[:, 0] = rng.uniform(-0.6, 0.6, (ntubes, 3))
        d = rng.normal(size=(ntubes, 3))
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        dirs = np.empty((ntubes, segs, 3))
        for i in range(segs):
            p = pts[:, i]
            r = np.linalg.norm(p, axis=-1, keepdims=True)
            want = d + 0.8 * rng.normal(size=(ntubes, 3)) - 4.0 * np.maximum(r - 0.5, 0) * p / np.maximum(r, 1e-9)
            o = want - np.sum(want * d, -1, keepdims=True) * d  # part orthogonal to the current direction
            on = np.linalg.norm(o, axis=-1, keepdims=True)
            ang = np.minimum(np.arctan2(on, np.sum(want * d, -1, keepdims=True)), max_turn)
            d = np.cos(ang) * d + np.sin(ang) * o / np.maximum(on, 1e-12)
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            dirs[:, i] = d
            pts[:, i + 1] = p + step * d
        # uniform per-tube shrink about the origin for the few walks that left the box (keeps them smooth)
        ext = np.abs(pts).max(axis=(1, 2))
        pts *= np.minimum(1.0, 0.95 / ext)[:, None, None]
        tan = np.concatenate([dirs[:, :1], dirs[:, :-1] + dirs[:, 1:], dirs[:, -1:]], 1)
        tan /= np.linalg.norm(tan, axis=-1, keepdims=True)
        # rotation-minimising frames (double reflection), vectorised over tubes
        ref = np.where(np.abs(tan[:, :1, 1:2]) < 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
        nrm = np.empty_like(tan)
        n0 = np.cross(tan[:, 0], ref[:, 0])
        nrm[:, 0] = n0 / np.linalg.norm(n0, axis=-1, keepdims=True)
        for i in range(segs):
            v1 = pts[:, i + 1] - pts[:, i]
            c1 = np.sum(v1 * v1, -1, keepdims=True) + 1e-30
            rL = nrm[:, i] - (2 / c1) * np.sum(v1 * nrm[:, i], -1, keepdims=True) * v1
            tL = tan[:, i] - (2 / c1) * np.sum(v1 * tan[:, i], -1, keepdims=True) * v1
            v2 = tan[:, i + 1] - tL
            c2 = np.sum(v2 * v2, -1, keepdims=True) + 1e-30
            n = rL - (2 / c2) * np.sum(v2 * rL, -1, keepdims=True) * v2
            n -= np.sum(n * tan[:, i + 1], -1, keepdims=True) * tan[:, i + 1]
            nrm[:, i + 1] = n / np.linalg.norm(n, axis=-1, keepdims=True)
        bin_ = np.cross(tan, nrm)
        phi = np.arange(sides) * (2 * math.pi / sides)
        ring = (np.cos(phi)[None, None, :, None] * nrm[:, :, None]
                + np.sin(phi)[None, None, :, None] * bin_[:, :, None])
        v = pts[:, :, None] + radius * ring  # (T, S+1, sides, 3)
        f1 = grid_faces(segs + 1, sides, wrap=True)[:, ::-1]  # reversed: outward normals
        nv = (segs + 1) * sides
        faces = (f1[None] + (np.arange(ntubes) * nv)[:, None, None]).reshape(-1, 3)
        floor = quad((-3, -1.1, -3), (0, 0, 6), (6, 0, 0))
        if colours == 1:
            groups = [("tubes", (v.reshape(-1, 3), faces), PALETTE[0])]
        else:  # tube i in group i mod n: its vertices and faces, renumbered within the group
            local = f1[None] + (np.arange(ntubes) // colours * nv)[:, None, None]
            groups = [(f"tubes{g}", (v[g::colours].reshape(-1, 3), local[g::colours].reshape(-1, 3)), PALETTE[g])
                      for g in range(min(colours, ntubes))]
        meshes = [part_mesh(name, part, albedo, opacity) for name, part, albedo in groups]
        meshes.append(part_mesh("floor", floor, (0.6, 0.6, 0.6)))
        cam = Camera(origin=(0.0, 0.8, 4.2), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=45.0)
        light = SpotLight(position=(2.0, 4.0, 3.0), target=(0.0, 0.0, 0.0), intensity=(60.0,) * 3,
                          cutoff_angle=35.0, up=(0.0, 1.0, 0.0))
        return Scene("hairball", meshes, cam, [light])
