"""The ``atrium`` scene: a Sponza-like courtyard whose triangle count is a parameter."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.meshio import box, box_parts, cylinder, half_ring, instances, merge, quad
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import SceneBuilder, SceneParams, part_mesh

# atrium layout (metres); see Atrium's docstring
_AT = dict(xh=15.0, zh=7.0, wall_h=12.0, za=4.0, pier_dx=3.0, depth=0.6, r_in=1.1, r_out=1.5)
_AT_STOREYS = (  # (shaft y0, shaft y1, radius, capital half size, capital height, band height, slab)
    (0.0, 3.5, 0.30, 0.40, 0.30, 0.5, 0.3),
    (6.1, 8.6, 0.25, 0.35, 0.25, 0.5, 0.3),
)
_AT_ARCHES_PER_ROW = 10  # pier positions -15, -12, ..., 15 (the end walls act as the outer piers)
_AT_COLUMNS_PER_ROW = 9
_AT_ROWS = 4  # 2 sides × 2 storeys
_AT_PIERS = np.arange(-_AT["xh"], _AT["xh"] + 1e-9, _AT["pier_dx"])  # column x positions + the end walls


def _atrium_fixed(xh, zh, wall_h, za, depth, **_):
    """Tessellation-independent parts of the atrium, by material."""
    d2 = depth / 2
    floor = quad((-xh, 0, -zh), (0, 0, 2 * zh), (2 * xh, 0, 0))
    room = box_parts((-xh, 0, -zh), (xh, wall_h, zh), 1, skip=("+y", "-y"), inward=True)
    walls = merge(room.values())
    gallery, trim = [], []
    for sgn in (1.0, -1.0):
        for y0, y1, rad, ch, cht, band, slab in _AT_STOREYS:
            spring = y1 + cht
            top = spring + _AT["r_out"]
            zin, zout = sgn * (za - d2), sgn * zh
            zb = sorted((sgn * (za - d2), sgn * (za + d2)))
            gallery.append(box((-xh, top, zb[0]), (xh, top + band, zb[1])))
            slab_lo = (-xh, top + band, min(zin, zout))
            slab_hi = (xh, top + band + slab, max(zin, zout))
            gallery.append(box(slab_lo, slab_hi))
            # capitals on top of the column shafts
            cap = box((-ch, y1, -ch), (ch, y1 + cht, ch))
            xs = _AT_PIERS[1:-1]
            trim.append(instances(cap, np.stack([xs, np.zeros_like(xs), np.full_like(xs, sgn * za)], -1)))
    return floor, walls, merge(gallery), merge(trim)


def _atrium_curtains(xh, zh, za, depth, **_):
    """Coloured cloths hanging in some upper-storey openings, just behind the arcade (Sponza-like)."""
    y0, y1, rad, ch, cht, band, slab = _AT_STOREYS[1]
    top = y1 + cht + _AT["r_in"] - 0.05
    parts = {"curtain_red": [], "curtain_green": [], "curtain_blue": []}
    names = list(parts)
    centres = (_AT_PIERS[:-1] + _AT_PIERS[1:]) / 2
    for i, cx in enumerate(centres[1:-1:2]):
        for sgn in (1.0, -1.0):
            z = sgn * (za + depth / 2 + 0.15)
            w = 2 * _AT["r_in"] - 0.2
            p0 = (cx - w / 2, y0 + 0.5, z)
            a, b = (w, 0, 0), (0, top - y0 - 0.5, 0)
            # face the courtyard (normal -sgn z)
            parts[names[i % 3]].append(quad(p0, a, b) if sgn < 0 else quad(p0, b, a))
    return {k: merge(v) for k, v in parts.items()}


def _atrium_count(fixed: int, around: int, rings: int, arch: int) -> int:
    cols = _AT_ROWS * _AT_COLUMNS_PER_ROW * 2 * around * rings
    arches = _AT_ROWS * _AT_ARCHES_PER_ROW * 8 * arch
    return fixed + cols + arches


def _atrium_tessellation(target: int, fixed: int):
    """Choose (column segments around, column rings, arch segments) whose count is nearest the target.

    Arches get half as many segments as a column has around (same angular step over 180°); rings are
    solved for; among choices within 2 % of the target the one with rings closest to around / 2 wins.
    """
    best, best_key = None, None
    for around in range(6, 2049):
        arch = max(3, around // 2)
        base = _atrium_count(fixed, around, 0, arch)
        per_ring = _AT_ROWS * _AT_COLUMNS_PER_ROW * 2 * around
        if base + per_ring > target * 1.5 and best is not None:
            break
        rings = max(1, round((target - base) / per_ring))
        n = _atrium_count(fixed, around, rings, arch)
        err = abs(n - target) / target
        key = (0, abs(rings - around / 2), err) if err <= 0.02 else (1, err, 0)
        if best_key is None or key < best_key:
            best, best_key = (around, rings, arch), key
    return best


@dataclass(frozen=True)
class AtriumParams(SceneParams):
    triangles: int = param(20000, "triangle count (the result is within 2 %)", lo=2000, hi=4_000_000)


class Atrium(SceneBuilder):
    """A Sponza-like two-storey courtyard of columns and arches; ``triangles`` sets the size.

    Layout (metres): floor x ∈ [-15, 15], z ∈ [-7, 7]; four outer walls 12 m high; open roof.
    Along both long sides (arcade lines z = ±4) two storeys of arcades: 9 round columns per row
    (ground storey r = 0.30 m, shafts y 0–3.5; upper storey r = 0.25 m, on the gallery floor at
    y = 6.1, shafts to 8.6) with square capitals, and 10 semicircular arches per row (inner radius
    1.1 m, outer 1.5 m, 0.6 m deep; the end walls act as the outer piers), a band above each arcade,
    the gallery floor (y 5.8–6.1) and the gallery roof (y 10.85–11.15) reaching back to the outer
    wall, and red/green/blue cloths hanging in some upper openings. The column and arch tessellation
    is chosen so the triangle count is within 2 % of ``triangles`` (any target in [2000, 4000000]).
    Camera: (-13, 1.8, -1) looking down the courtyard at (5, 4.5, 0.5), vertical fov 60°.
    Light: a spot high above the open roof at (-6, 24, -2.5) aimed at (1, 0, 1), cutoff 50°,
    beam 40°, 1500 W/sr; the galleries behind the arcades receive mostly indirect light.
    """

    name = "atrium"
    Params = AtriumParams

    def build(self, p: AtriumParams) -> Scene:
        target = p.triangles
        floor, walls, gallery, trim = _atrium_fixed(**_AT)
        curtains = _atrium_curtains(**_AT)
        fixed = (sum(len(part[1]) for part in (floor, walls, gallery, trim))
                 + sum(len(part[1]) for part in curtains.values()))
        around, rings, arch = _atrium_tessellation(target, fixed)

        cols, arches = [], []
        centres = (_AT_PIERS[:-1] + _AT_PIERS[1:]) / 2
        xs = _AT_PIERS[1:-1]
        for y0, y1, rad, ch, cht, band, slab in _AT_STOREYS:
            shaft = cylinder(rad, y0, y1, around, rings)
            a = half_ring(_AT["r_in"], _AT["r_out"], _AT["depth"], arch)
            for sgn in (1.0, -1.0):
                z = sgn * _AT["za"]
                cols.append(instances(shaft, np.stack([xs, np.zeros_like(xs), np.full_like(xs, z)], -1)))
                arches.append(instances(a, np.stack([centres, np.full_like(centres, y1 + cht),
                                                      np.full_like(centres, z)], -1)))
        meshes = [
            part_mesh("floor", floor, (0.62, 0.58, 0.52)),
            part_mesh("walls", walls, (0.70, 0.66, 0.58)),
            part_mesh("columns", merge(cols), (0.75, 0.72, 0.66)),
            part_mesh("arches", merge(arches), (0.72, 0.68, 0.60)),
            part_mesh("galleries", gallery, (0.60, 0.58, 0.55)),
            part_mesh("capitals", trim, (0.68, 0.64, 0.58)),
            part_mesh("curtain_red", curtains["curtain_red"], (0.60, 0.08, 0.06)),
            part_mesh("curtain_green", curtains["curtain_green"], (0.10, 0.45, 0.12)),
            part_mesh("curtain_blue", curtains["curtain_blue"], (0.08, 0.15, 0.55)),
        ]
        cam = Camera(origin=(-13.0, 1.8, -1.0), target=(5.0, 4.5, 0.5), up=(0, 1, 0), fov_y=60.0)
        light = SpotLight(position=(-6.0, 24.0, -2.5), target=(1.0, 0.0, 1.0), intensity=(1500.0,) * 3,
                          cutoff_angle=50.0, beam_width=40.0, up=(1.0, 0.0, 0.0))
        return Scene("atrium", meshes, cam, [light])

