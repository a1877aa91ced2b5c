"""The ``city`` scene: a procedural town, the stand-in for Rungholt."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.meshio import box_parts, merge, quad
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import SceneBuilder, SceneParams, part_mesh

# city layout (metres); see City's docstring
_CITY = dict(blocks=8, block=40.0, street=8.0, houses=4)


def _tri_grid(a, b, c, n: int):
    """Triangle (a apex; b, c base) split into n² triangles; front normal (b - a) × (c - a)."""
    a, b, c = (np.asarray(x, np.float64) for x in (a, b, c))
    rows = [a + (i / n) * ((b - a)[None] + (np.arange(i + 1)[:, None] / max(i, 1)) * (c - b)[None])
            for i in range(n + 1)]
    v = np.concatenate(rows)
    start = np.concatenate([[0], np.cumsum([i + 1 for i in range(n + 1)])])
    f = []
    for i in range(n):
        r0, r1 = start[i], start[i + 1]
        for j in range(i + 1):
            f.append((r0 + j, r1 + j, r1 + j + 1))
            if j < i:
                f.append((r0 + j, r1 + j + 1, r0 + j + 1))
    return v, np.array(f, np.int64)


def _city_house_templates(n: int):
    """Unit walls (the four sides of [0, 1]³) and a unit gable roof (ridge along x at z = ½, y ∈ [0, 1]),
    each side split into n × n cells, each gable into n² triangles: 14 n² triangles."""
    walls = merge(box_parts((0, 0, 0), (1, 1, 1), n, skip=("+y", "-y")).values())
    roof = merge([quad((0, 0, 0), (0, 1, 0.5), (1, 0, 0), n), quad((0, 1, 0.5), (0, -1, 0.5), (1, 0, 0), n),
                  _tri_grid((0, 1, 0.5), (0, 0, 0), (0, 0, 1), n), _tri_grid((1, 1, 0.5), (1, 0, 1), (1, 0, 0), n)])
    return walls, roof


@dataclass(frozen=True)
class CityParams(SceneParams):
    triangles: int = param(200000, "triangle count (the result is within 1 %)", lo=16000, hi=20_000_000)
    seed: int = param(0, "seed of the houses' sizes and roofs", lo=0, hi=2**63 - 1)


class City(SceneBuilder):
    """A procedural medieval town of gabled houses: the stand-in for Rungholt (archer2019's large outdoor
    scene, about 7 M triangles); ``triangles`` sets the size.

    Layout (metres): 8 × 8 city blocks of 40 m separated by 8 m streets (the town spans x, z ∈
    [-188, 188]), 4 × 4 houses per block on 10 m lots: footprints 6–9 m × 6–9 m, walls 4–14 m high, a
    gable roof 2–6 m high whose ridge runs along x or z, drawn per house from ``seed``; one ground quad
    reaching 20 m beyond the town. Every wall and roof plane is split into n × n cells (gables into n²
    triangles): 1024 houses × 14 n² triangles, n and the ground's grid chosen so the total is within
    1 % of ``triangles`` (any target in [16000, 20000000]; 7 M gives n = 22).
    Camera: (-210, 150, -210) looking at (10, 0, 10), vertical fov 50°. Light: a spot high above,
    (-120, 420, -60) aimed at the town's centre, cutoff 40°, beam 35°, 500 000 W/sr (about 3 W/m² on the
    ground, the atrium's level).
    """

    name = "city"
    Params = CityParams

    def build(self, p: CityParams) -> Scene:
        target, seed = p.triangles, p.seed
        rng = np.random.default_rng(seed)
        nb, blk, st, nh = _CITY["blocks"], _CITY["block"], _CITY["street"], _CITY["houses"]
        lot = blk / nh
        span = nb * blk + (nb - 1) * st
        bx = -span / 2 + np.arange(nb) * (blk + st)
        lots = (bx[:, None] + np.arange(nh)[None] * lot).reshape(-1)            # lot corners along one axis
        X, Z = (g.reshape(-1) for g in np.meshgrid(lots, lots, indexing="ij"))
        H = len(X)
        w, d = rng.uniform(6.0, 9.0, H), rng.uniform(6.0, 9.0, H)
        h, rh = rng.uniform(4.0, 14.0, H), rng.uniform(2.0, 6.0, H)
        along_z = rng.random(H) < 0.5
        x0 = X + (lot - w) / 2
        z0 = Z + (lot - d) / 2
        n = max(1, int(round(math.sqrt(max(target - 2, 14 * H) / (14 * H)))))
        while n > 1 and 14 * H * n * n > target - 2:
            n -= 1
        walls_t, roof_t = _city_house_templates(n)

        def place(tpl, sx, sy, sz, ox, oy, oz, swap):
            v, f = tpl
            v = np.broadcast_to(v, (H,) + v.shape).copy()
            v[swap] = v[swap][..., [2, 1, 0]]  # ridge along z: x and z exchanged (a mirror: faces reversed below)
            v = v * np.stack([sx, sy, sz], -1)[:, None] + np.stack([ox, oy, oz], -1)[:, None]
            ff = np.broadcast_to(f, (H,) + f.shape).copy()
            ff[swap] = ff[swap][..., ::-1]
            ff += (np.arange(H) * len(tpl[0]))[:, None, None]
            return v.reshape(-1, 3), ff.reshape(-1, 3)

        zero = np.zeros(H)
        walls = place(walls_t, w, h, d, x0, zero, z0, np.zeros(H, bool))
        roof = place(roof_t, np.where(along_z, d, w), rh, np.where(along_z, w, d), x0, h, z0, along_z)
        rest = max(target - len(walls[1]) - len(roof[1]), 2)
        g = max(1, int(round(math.sqrt(rest / 2))))
        half = span / 2 + 20.0
        ground = quad((-half, 0, -half), (0, 0, 2 * half), (2 * half, 0, 0), g)
        meshes = [part_mesh("ground", ground, (0.38, 0.42, 0.30)),
                  part_mesh("walls", walls, (0.78, 0.74, 0.66)),
                  part_mesh("roofs", roof, (0.55, 0.22, 0.16))]
        cam = Camera(origin=(-210.0, 150.0, -210.0), target=(10.0, 0.0, 10.0), up=(0, 1, 0), fov_y=50.0)
        light = SpotLight(position=(-120.0, 420.0, -60.0), target=(0.0, 0.0, 0.0), intensity=(5.0e5,) * 3,
                          cutoff_angle=40.0, beam_width=35.0, up=(0.0, 1.0, 0.0))
        return Scene("city", meshes, cam, [light])

