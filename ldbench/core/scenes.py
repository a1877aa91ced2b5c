"""Built-in scenes and the scene dispatcher.

``load_scene(spec, **params)`` turns a scene specification into a :class:`~ldbench.core.scene.Scene`:

* a built-in name (``cornell``, ``atrium``, ``hairball``, ``mesh``), optionally with parameters
  appended as ``name:key=value,key=value`` (e.g. ``atrium:triangles=260000``);
* a path ending in ``.xml``: a Mitsuba 3 scene file (:func:`ldbench.core.mitsuba_xml.load_mitsuba_xml`;
  ``params`` then override the file's ``<default>`` values);
* a path to a mesh file (``.ply``, ``.obj``, ``.stl``, ``.off``): the ``mesh`` scene (mesh in an open box);
* a registered real scene (``sponza``, ``sibenik``, ``dragon``, ...; ``ldbench/core/scene_registry.toml``),
  read from the scene cache after its checksums are verified (:func:`build_registered`).

Every builder is deterministic and vectorised numpy (300k triangles in well under a second), and gives
a camera and one spot light that lights most of what the camera sees, so ``direct`` and ``indirect``
are meaningful. Conventions (docs/design.md): metres, y up, right-handed, triangles counter-clockwise seen
from the front (walls face into the room, solids face outwards); methods treat them as two-sided.
``scene.params`` holds exactly the builder parameters used, defaults included (so
``load_scene(builder, **scene.params)`` rebuilds the same scene — the builder is ``scene.name``, or
``mesh`` for mesh scenes, which are named after the file; derived quantities such as the atrium's
tessellation follow deterministically from the parameters).
"""
from __future__ import annotations

import inspect
import math
import os
import re
from pathlib import Path

import numpy as np

from .errors import LdbenchError
from .meshio import (box, box_parts, cylinder, grid_faces, half_ring, instances, merge, quad, read_mesh,
                     read_mtl, rot_y, rotation)
from .scene import Camera, Mesh, Scene, SpotLight

MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off")

# Cornell box albedos (linear RGB; the values of Bitterli's / the PBRT-v3 Cornell box).
WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)


# ---------------------------------------------------------------------------------------------------
# parameter coercion (values may come from TOML, the command line as strings, or Python)

def _int_param(scene: str, name: str, value, lo: int, hi: int) -> int:
    v = None
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        v = int(value)
    elif isinstance(value, float) and value.is_integer():
        v = int(value)
    elif isinstance(value, str):
        try:
            f = float(value.strip().replace("_", ""))
            if f.is_integer():
                v = int(f)
        except ValueError:
            pass
    if v is None:
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} must be an integer, got {value!r}")
    if not lo <= v <= hi:
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} = {v} out of range [{lo}, {hi}]")
    return v


def _albedo_param(scene: str, name: str, value) -> tuple:
    try:
        if isinstance(value, str):
            vals = [float(x) for x in value.replace(",", " ").split()]
        elif np.isscalar(value):
            vals = [float(value)]
        else:
            vals = [float(x) for x in value]
        if len(vals) == 1:
            vals = vals * 3
        if len(vals) != 3 or not all(math.isfinite(x) for x in vals):
            raise ValueError
    except (TypeError, ValueError):
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} must be 1 or 3 numbers in [0, 1], "
                           f"got {value!r}") from None
    if min(vals) < 0 or max(vals) > 1:
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} = {tuple(vals)} outside [0, 1]")
    return tuple(vals)


def _float_param(scene: str, name: str, value, lo: float, hi: float) -> float:
    try:
        if isinstance(value, bool):
            raise ValueError
        v = float(value.strip()) if isinstance(value, str) else float(value)
    except (TypeError, ValueError):
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} must be a number, got {value!r}") from None
    if not lo <= v <= hi:
        raise LdbenchError(f"scene {scene!r}: parameter {name!r} = {v} out of range [{lo}, {hi}]")
    return v


def _mesh(name, part, albedo, opacity=1.0) -> Mesh:
    v, f = part
    return Mesh(name, v.astype(np.float32), f.astype(np.int32), albedo, opacity)


# ---------------------------------------------------------------------------------------------------
# builders

def build_cornell(subdivide=0) -> Scene:
    """The Cornell box with the short and the tall block, normalised to a 2 m box, lit by a spot light.

    Geometry (metres): x ∈ [-1, 1] (red wall at x = -1 on the left, green wall at x = +1 on the
    right), floor y = 0, ceiling y = 2, back wall z = -1, front (z = +1) open. The blocks are those
    of Bitterli's / PBRT's Cornell box (short block 0.6 m high at (0.33, 0.37), tall block 1.2 m high
    at (-0.34, -0.29), rotated about y); their hidden bottom faces are left out. 30 triangles;
    ``subdivide`` = s splits every quad into (s+1)² cells, 30 (s+1)² triangles.
    Camera: (0, 1, 3.9) looking at (0, 1, 0), vertical fov 39.3077° (the classic Cornell camera's
    distance ratio). Light: a spot at (0, 1.95, 0) pointing straight down, cutoff 60°, beam 45°,
    intensity 10 W/sr (white).
    """
    s = _int_param("cornell", "subdivide", subdivide, 0, 128)
    n = s + 1
    walls = box_parts((-1, 0, -1), (1, 2, 1), n, skip=("+z",), inward=True)
    meshes = [
        _mesh("floor", walls["-y"], WHITE),
        _mesh("ceiling", walls["+y"], WHITE),
        _mesh("back_wall", walls["-z"], WHITE),
        _mesh("left_wall", walls["-x"], RED),
        _mesh("right_wall", walls["+x"], GREEN),
    ]
    # (centre x, centre z, size x, height, size z, rotation about y in degrees): Bitterli's blocks.
    blocks = {"short_block": (0.328631, 0.374592, 0.595, 0.6, 0.604, 73.36),
              "tall_block": (-0.335439, -0.291415, 0.607, 1.2, 0.598, 19.19)}
    for name, (cx, cz, sx, h, sz, ang) in blocks.items():
        v, f = box((-sx / 2, 0, -sz / 2), (sx / 2, h, sz / 2), n, skip=("-y",))
        v = v @ rot_y(ang).T + np.array([cx, 0, cz])
        meshes.append(_mesh(name, (v, f), WHITE))
    cam = Camera(origin=(0.0, 1.0, 3.9), target=(0.0, 1.0, 0.0), up=(0, 1, 0), fov_y=39.3077)
    light = SpotLight(position=(0.0, 1.95, 0.0), target=(0.0, 0.0, 0.0), intensity=(10.0, 10.0, 10.0),
                      cutoff_angle=60.0, beam_width=45.0, up=(0.0, 0.0, -1.0))
    return Scene("cornell", meshes, cam, [light], params={"subdivide": s})


# atrium layout (metres); see build_atrium's docstring
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


def build_atrium(triangles=20000) -> Scene:
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
    target = _int_param("atrium", "triangles", triangles, 2000, 4_000_000)
    floor, walls, gallery, trim = _atrium_fixed(**_AT)
    curtains = _atrium_curtains(**_AT)
    fixed = sum(len(p[1]) for p in (floor, walls, gallery, trim)) + sum(len(p[1]) for p in curtains.values())
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
        _mesh("floor", floor, (0.62, 0.58, 0.52)),
        _mesh("walls", walls, (0.70, 0.66, 0.58)),
        _mesh("columns", merge(cols), (0.75, 0.72, 0.66)),
        _mesh("arches", merge(arches), (0.72, 0.68, 0.60)),
        _mesh("galleries", gallery, (0.60, 0.58, 0.55)),
        _mesh("capitals", trim, (0.68, 0.64, 0.58)),
        _mesh("curtain_red", curtains["curtain_red"], (0.60, 0.08, 0.06)),
        _mesh("curtain_green", curtains["curtain_green"], (0.10, 0.45, 0.12)),
        _mesh("curtain_blue", curtains["curtain_blue"], (0.08, 0.15, 0.55)),
    ]
    cam = Camera(origin=(-13.0, 1.8, -1.0), target=(5.0, 4.5, 0.5), up=(0, 1, 0), fov_y=60.0)
    light = SpotLight(position=(-6.0, 24.0, -2.5), target=(1.0, 0.0, 1.0), intensity=(1500.0,) * 3,
                      cutoff_angle=50.0, beam_width=40.0, up=(1.0, 0.0, 0.0))
    return Scene("atrium", meshes, cam, [light], params={"triangles": target})


def build_hairball(triangles=20000, seed=0, opacity=1.0) -> Scene:
    """Dense random tubes in the box [-1, 1]³ (high depth complexity) above a floor.

    Each tube is a thin open cylinder (6 sides, 10 segments of 0.12 m: 120 triangles) swept with
    rotation-minimising frames along a smooth random walk (each step turns by at most 35°, pulled
    towards the centre) that stays inside [-0.95, 0.95]³.
    The number of tubes is round((triangles - 2) / 120) (at least 1); the tube radius shrinks with
    the count (0.6 / √tubes, clamped to [0.004, 0.05] m), so the depth complexity grows like √tubes
    (about 5 layers at 20k triangles, 20 at 260k).
    A 6 m floor quad at y = -1.1 receives the shadow. Deterministic for a given ``seed``.
    ``opacity``: the tubes' α for the ``oit`` effect (the floor stays opaque).
    Camera: (0, 0.8, 4.2) looking at the origin, vertical fov 45°.
    Light: a spot at (2, 4, 3) aimed at the origin, cutoff 35°, beam 26.25°, 60 W/sr.
    """
    target = _int_param("hairball", "triangles", triangles, 200, 4_000_000)
    seed = _int_param("hairball", "seed", seed, 0, 2**63 - 1)
    opacity = _float_param("hairball", "opacity", opacity, 0.0, 1.0)
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
    ring = (np.cos(phi)[None, None, :, None] * nrm[:, :, None] + np.sin(phi)[None, None, :, None] * bin_[:, :, None])
    v = pts[:, :, None] + radius * ring  # (T, S+1, sides, 3)
    f1 = grid_faces(segs + 1, sides, wrap=True)[:, ::-1]  # reversed: outward normals
    nv = (segs + 1) * sides
    faces = (f1[None] + (np.arange(ntubes) * nv)[:, None, None]).reshape(-1, 3)
    tubes = (v.reshape(-1, 3), faces)
    floor = quad((-3, -1.1, -3), (0, 0, 6), (6, 0, 0))
    meshes = [_mesh("tubes", tubes, (0.72, 0.55, 0.38), opacity), _mesh("floor", floor, (0.6, 0.6, 0.6))]
    cam = Camera(origin=(0.0, 0.8, 4.2), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=45.0)
    light = SpotLight(position=(2.0, 4.0, 3.0), target=(0.0, 0.0, 0.0), intensity=(60.0,) * 3,
                      cutoff_angle=35.0, up=(0.0, 1.0, 0.0))
    return Scene("hairball", meshes, cam, [light], params={"triangles": target, "seed": seed, "opacity": opacity})


def build_mesh(path=None, albedo=(0.8, 0.8, 0.8)) -> Scene:
    """A mesh file (PLY/OBJ/STL/OFF) standing on the floor of an open box (e.g. the Stanford dragon).

    The mesh (all parts merged, loaded with trimesh, ``process=False``) is scaled uniformly so that its
    largest bounding-box side is 1 m, centred at x = z = 0 and put on the floor (min y = 0), with
    the diffuse ``albedo``. The box: floor and ceiling-less walls of x, z ∈ [-1.25, 1.25], walls 2 m
    high: back (white), left (red), right (green); front and top open.
    Camera: (0, 0.9, 3.6) looking at (0, 0.5, 0), vertical fov 40°.
    Light: a spot at (0.9, 2.4, 1.8) aimed at (0, 0.35, 0), cutoff 45°, beam 33.75°, 12 W/sr.
    """
    if path is None or str(path).strip() == "":
        raise LdbenchError("scene 'mesh' needs the parameter 'path' (a .ply or .obj file)")
    albedo = _albedo_param("mesh", "albedo", albedo)
    v, f = read_mesh(path)
    name = Path(str(path)).stem
    cam = Camera(origin=(0.0, 0.9, 3.6), target=(0.0, 0.5, 0.0), up=(0, 1, 0), fov_y=40.0)
    light = SpotLight(position=(0.9, 2.4, 1.8), target=(0.0, 0.35, 0.0), intensity=(12.0,) * 3,
                      cutoff_angle=45.0, up=(0.0, 1.0, 0.0))
    return Scene(name, _object_in_box(name, v, f, albedo, str(path)), cam, [light],
                 params={"path": str(path), "albedo": list(albedo)})


def _object_in_box(name, v, f, albedo, path) -> list:
    """The mesh scene's layout: the object scaled to a largest side of 1 m, centred at x = z = 0 on the
    floor of the open 2.5 × 2 × 2.5 m box (floor and back wall white, left red, right green)."""
    lo, hi = v.min(0), v.max(0)
    ext = float((hi - lo).max())
    if not ext > 0:
        raise LdbenchError(f"cannot read mesh {path}: the mesh has zero extent")
    v = (v - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])) / ext
    room = box_parts((-1.25, 0, -1.25), (1.25, 2.0, 1.25), 1, skip=("+z", "+y"), inward=True)
    return [
        _mesh(name, (v, f), albedo),
        _mesh("floor", room["-y"], WHITE),
        _mesh("back_wall", room["-z"], WHITE),
        _mesh("left_wall", room["-x"], RED),
        _mesh("right_wall", room["+x"], GREEN),
    ]


def build_registered(name: str, root=None) -> Scene:
    """A registered real scene, built from its files in the scene cache (``root``: another cache).

    The entry in ``ldbench/core/scene_registry.toml`` says how (``load.kind``): ``mesh`` (one file, one
    albedo), ``parts`` (one file per material, albedo = the MTL's Kd), ``object`` (rotated, then placed
    in the :func:`build_mesh` box) or ``xml`` (a Mitsuba 3 file, camera from the file). ``load.scale``
    converts model units to metres (geometry and the file's camera); the spot light, and the camera
    unless the file gives it, are the entry's. Checksums are verified before anything is read; a scene
    that is not fetched is one :class:`LdbenchError` line saying how to fetch it.
    """
    from fnmatch import fnmatch

    from . import scene_registry

    entry = scene_registry.get(name)
    folder = scene_registry.verified_root(name, root)
    ld, camera = entry.load, entry.camera
    s = float(ld.get("scale", 1.0))
    warnings = [entry.warning] if entry.warning else []
    if ld["kind"] == "mesh":
        v, f = read_mesh(folder / ld["mesh"])
        meshes = [_mesh(Path(ld["mesh"]).stem, (v * s, f), tuple(ld["albedo"]))]
    elif ld["kind"] == "parts":
        kd = read_mtl(folder / ld["mtl"])
        meshes = []
        for spec in entry.files:
            if not fnmatch(spec.path, ld["parts"]):
                continue
            mat = Path(spec.path).stem
            if mat not in kd:
                raise LdbenchError(f"scene {name!r}: material {mat!r} has no Kd in {folder / ld['mtl']}")
            v, f = read_mesh(folder / spec.path)
            meshes.append(_mesh(mat, (v * s, f), kd[mat]))
    elif ld["kind"] == "object":
        v, f = read_mesh(folder / ld["mesh"])
        for ax, ay, az, deg in ld.get("rotate", ()):
            v = v @ rotation((ax, ay, az), deg).T
        meshes = _object_in_box(Path(ld["mesh"]).stem, v, f, tuple(ld["albedo"]), folder / ld["mesh"])
    else:  # xml
        from .mitsuba_xml import load_mitsuba_xml

        sc = load_mitsuba_xml(folder / ld["xml"])
        meshes = [Mesh(m.name, m.vertices * s, m.faces, m.albedo, m.opacity) for m in sc.meshes]
        c = sc.camera
        camera = camera or Camera(np.multiply(c.origin, s), np.multiply(c.target, s), c.up, c.fov_y)
        warnings += sc.warnings
    return Scene(name, meshes, camera, [entry.light], params={}, source=f"registry:{name}", warnings=warnings)


def _catmull_rom(points, samples_per_segment: int) -> np.ndarray:
    """A uniform Catmull-Rom curve through ``points`` (K, D), ends repeated; (K-1)·n + 1 samples."""
    p = np.asarray(points, np.float64)
    p = np.concatenate([p[:1], p, p[-1:]])
    t = np.linspace(0.0, 1.0, samples_per_segment, endpoint=False)[:, None]
    out = []
    for i in range(1, len(p) - 2):
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        out.append(0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t ** 2
                          + (3 * p1 - p0 - 3 * p2 + p3) * t ** 3))
    out.append(p[-2][None])
    return np.concatenate(out)


def _outward(v, f):
    """Faces reversed if the closed part's signed volume is negative (normals point outwards)."""
    tri = v[f]
    vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum()
    return (v, f if vol > 0 else f[:, ::-1])


def _revolved(profile: np.ndarray, around: int):
    """Closed surface of revolution about y of a (r, y) profile whose first and last points are on the
    axis (r = 0): one pole vertex at each end, fans to the first and last rings."""
    rings = profile[1:-1]
    phi = np.arange(around) * (2 * math.pi / around)
    ring_v = np.stack([rings[:, :1] * np.cos(phi), np.repeat(rings[:, 1:], around, 1),
                       rings[:, :1] * np.sin(phi)], -1).reshape(-1, 3)
    n = len(rings) * around
    v = np.concatenate([ring_v, [[0.0, profile[0, 1], 0.0]], [[0.0, profile[-1, 1], 0.0]]])
    j = np.arange(around)
    bottom = np.stack([np.full(around, n), j, (j + 1) % around], -1)
    last = (len(rings) - 1) * around
    top = np.stack([np.full(around, n + 1), last + (j + 1) % around, last + j], -1)
    return _outward(v, np.concatenate([grid_faces(len(rings), around, wrap=True), bottom, top]))


def _tube(centre: np.ndarray, radius: np.ndarray, around: int):
    """Closed tube (end caps) along a curve in the z = 0 plane; frames (−t_y, t_x, 0), (0, 0, 1)."""
    t = np.gradient(centre, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    nrm = np.stack([-t[:, 1], t[:, 0], np.zeros(len(t))], -1)
    phi = np.arange(around) * (2 * math.pi / around)
    ring = (np.cos(phi)[None, :, None] * nrm[:, None] + np.sin(phi)[None, :, None] * np.array([0.0, 0.0, 1.0]))
    v = (centre[:, None] + radius[:, None, None] * ring).reshape(-1, 3)
    n, j = len(v), np.arange(around)
    last = (len(centre) - 1) * around
    v = np.concatenate([v, centre[:1], centre[-1:]])
    caps = [np.stack([np.full(around, n), (j + 1) % around, j], -1),
            np.stack([np.full(around, n + 1), last + j, last + (j + 1) % around], -1)]
    return _outward(v, np.concatenate([grid_faces(len(centre), around, wrap=True)[:, ::-1], *caps]))


# teapot outline in body units (body radius 1): profile (r, y) of the body and lid, spout and handle
# centre lines (x, y) in the z = 0 plane with their radii at the control points
_TEAPOT_BODY = ((0.0, 0.0), (0.62, 0.0), (0.80, 0.03), (0.93, 0.13), (1.0, 0.32), (0.98, 0.50), (0.90, 0.64),
                (0.78, 0.74), (0.70, 0.78), (0.66, 0.80), (0.56, 0.87), (0.40, 0.93), (0.22, 0.96),
                (0.10, 0.98), (0.09, 1.04), (0.16, 1.08), (0.18, 1.12), (0.13, 1.17), (0.0, 1.19))
_TEAPOT_SPOUT = ((0.70, 0.22, 0.17), (1.05, 0.30, 0.15), (1.30, 0.48, 0.12), (1.42, 0.70, 0.10),
                 (1.55, 0.90, 0.085), (1.72, 1.00, 0.075))
_TEAPOT_HANDLE = ((-0.70, 0.73, 0.075), (-1.10, 0.76, 0.075), (-1.36, 0.66, 0.075), (-1.44, 0.46, 0.075),
                  (-1.34, 0.26, 0.075), (-1.10, 0.16, 0.075), (-0.80, 0.15, 0.075))
TEAPOT_SCALE = 0.35  # metres per body unit


def build_teapot(segments=48, opacity=0.5) -> Scene:
    """A teapot-like solid for order-independent transparency (yang2010 Table 1's teapot).

    Three closed meshes, each watertight, that interpenetrate as a modelled teapot does: a body with
    lid and knob (a surface of revolution about y of a Catmull-Rom profile, 0.7 m wide, 0.42 m
    tall), a spout and a handle (closed tubes with end caps along curves in the z = 0 plane, their
    inner ends inside the body). ``segments`` vertices around every ring (and as many rings along
    the body, half as many along spout and handle); about 4.5 · segments² triangles (10k at 48).
    Albedo (0.80, 0.30, 0.10), ``opacity`` α for the ``oit`` effect (0 … 1). No floor.
    Camera: (0.35, 0.85, 2.1) looking at (0.07, 0.18, 0), vertical fov 35°.
    Light: a spot at (1.0, 2.2, 1.6) aimed at (0.07, 0.2, 0), cutoff 40°, beam 30°, 8 W/sr.
    """
    seg = _int_param("teapot", "segments", segments, 8, 1024)
    opacity = _float_param("teapot", "opacity", opacity, 0.0, 1.0)
    body = _catmull_rom(_TEAPOT_BODY, max(2, round(seg / (len(_TEAPOT_BODY) - 1))))
    parts = {"body": _revolved(body, seg)}
    along = max(2, round(seg / 2 / (len(_TEAPOT_SPOUT) - 1)))
    for name, ctl in (("spout", _TEAPOT_SPOUT), ("handle", _TEAPOT_HANDLE)):
        c = _catmull_rom(np.asarray(ctl)[:, :2], along)
        r = np.interp(np.linspace(0, 1, len(c)), np.linspace(0, 1, len(ctl)), np.asarray(ctl)[:, 2])
        parts[name] = _tube(np.concatenate([c, np.zeros((len(c), 1))], 1), r, seg)
    albedo = (0.80, 0.30, 0.10)
    meshes = [_mesh(k, (v * TEAPOT_SCALE, f), albedo, opacity) for k, (v, f) in parts.items()]
    cam = Camera(origin=(0.35, 0.85, 2.1), target=(0.07, 0.18, 0.0), up=(0, 1, 0), fov_y=35.0)
    light = SpotLight(position=(1.0, 2.2, 1.6), target=(0.07, 0.2, 0.0), intensity=(8.0,) * 3,
                      cutoff_angle=40.0, beam_width=30.0, up=(0.0, 1.0, 0.0))
    return Scene("teapot", meshes, cam, [light], params={"segments": seg, "opacity": opacity})


def build_transparent_dragon(opacity=0.5, albedo=(0.15, 0.45, 0.75)) -> Scene:
    """The Stanford dragon, transparent, in an opaque open box (yang2010 Table 1, Fig. 2).

    The registered ``dragon`` scene (``ldbench scenes fetch dragon`` first) with the dragon at ``opacity``
    α for the ``oit`` effect and the given ``albedo``; the floor and walls stay opaque. Camera, light and
    layout are the registered scene's."""
    opacity = _float_param("transparent_dragon", "opacity", opacity, 0.0, 1.0)
    albedo = _albedo_param("transparent_dragon", "albedo", albedo)
    sc = build_registered("dragon")
    m = sc.meshes[0]
    meshes = [Mesh(m.name, m.vertices, m.faces, albedo, opacity)] + list(sc.meshes[1:])
    return Scene("transparent_dragon", meshes, sc.camera, sc.lights,
                 params={"opacity": opacity, "albedo": list(albedo)}, source=sc.source, warnings=sc.warnings)


# city layout (metres); see build_city's docstring
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


def build_city(triangles=200000, seed=0) -> Scene:
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
    target = _int_param("city", "triangles", triangles, 16000, 20_000_000)
    seed = _int_param("city", "seed", seed, 0, 2**63 - 1)
    rng = np.random.default_rng(seed)
    nb, blk, st, nh = _CITY["blocks"], _CITY["block"], _CITY["street"], _CITY["houses"]
    lot = blk / nh
    span = nb * blk + (nb - 1) * st
    bx = -span / 2 + np.arange(nb) * (blk + st)
    lots = (bx[:, None] + np.arange(nh)[None] * lot).reshape(-1)            # lot corners along one axis
    X, Z = np.meshgrid(lots, lots, indexing="ij")
    X, Z = X.reshape(-1), Z.reshape(-1)
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
    meshes = [_mesh("ground", ground, (0.38, 0.42, 0.30)), _mesh("walls", walls, (0.78, 0.74, 0.66)),
              _mesh("roofs", roof, (0.55, 0.22, 0.16))]
    cam = Camera(origin=(-210.0, 150.0, -210.0), target=(10.0, 0.0, 10.0), up=(0, 1, 0), fov_y=50.0)
    light = SpotLight(position=(-120.0, 420.0, -60.0), target=(0.0, 0.0, 0.0), intensity=(5.0e5,) * 3,
                      cutoff_angle=40.0, beam_width=35.0, up=(0.0, 1.0, 0.0))
    return Scene("city", meshes, cam, [light], params={"triangles": target, "seed": seed})


BUILDERS = {
    "cornell": build_cornell,
    "atrium": build_atrium,
    "hairball": build_hairball,
    "mesh": build_mesh,
    "teapot": build_teapot,
    "transparent_dragon": build_transparent_dragon,
    "city": build_city,
}


# ---------------------------------------------------------------------------------------------------
# dispatch

def _builder_params(name: str) -> dict:
    sig = inspect.signature(BUILDERS[name])
    return {k: p.default for k, p in sig.parameters.items()}


def doc_summary(doc: str) -> str:
    """The first sentence of a docstring's first paragraph, on one line, without RST literal marks.

    A sentence ends at a full stop followed by a space and a capital letter, or at the paragraph's end,
    so "Fig. 2" or a sentence wrapped over several lines stays whole."""
    para = " ".join(" ".join((doc or "").strip().split("\n\n", 1)[0].split()).split())
    para = para.replace("``", "")
    m = re.search(r"\.\s+(?=[A-Z])", para)
    return para[: m.start() + 1] if m else para


def list_scenes() -> list[dict]:
    """One dict per built-in scene: ``name``, ``description`` (its docstring's first sentence, one line:
    :func:`doc_summary`), ``parameters`` (name → default)."""
    out = []
    for name, fn in BUILDERS.items():
        doc = inspect.getdoc(fn) or ""
        defaults = {k: (list(v) if isinstance(v, tuple) else v) for k, v in _builder_params(name).items()}
        out.append({"name": name, "description": doc_summary(doc), "parameters": defaults, "doc": doc})
    return out


#: An ad-hoc ``ldbench run --effect ao`` without ``--d-max`` on a scene with no registered d_max uses
#: this fraction of the scene's largest bounding-box extent: the small radius of the aalund2015 AO
#: suites (0.1 m in the 2 m Cornell box, 1.5 m in the 30 m atrium), where AO looks like AO and screen
#: space has the information it needs. Unbounded AO leaves enclosed scenes nearly black.
DEFAULT_D_MAX_FRACTION = 0.05


def default_d_max(spec, **params) -> tuple[float, str]:
    """The AO distance for a scene when the user gives none: ``(d_max, where it comes from)``.

    A registered scene's ``d_max`` (ldbench/core/scene_registry.toml) if it has one, else
    :data:`DEFAULT_D_MAX_FRACTION` of the largest extent of the scene's bounding box (3 significant
    digits). Suites state their d_max; this is for ad-hoc runs only."""
    from .scene_registry import registry

    name = spec.split(":", 1)[0] if isinstance(spec, str) else None
    entry = registry().get(name) if name else None
    if entry is not None and entry.d_max is not None:
        return float(entry.d_max), f"registered for scene {name!r}"
    lo, hi = load_scene(spec, **params).bounds()
    extent = float(np.max(hi - lo))
    d = float(f"{DEFAULT_D_MAX_FRACTION * extent:.3g}")
    return d, f"{DEFAULT_D_MAX_FRACTION:.0%} of the scene's largest bounding-box extent {extent:.3g}"


def _parse_inline_params(text: str, spec: str) -> dict:
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        if "=" not in item:
            raise LdbenchError(f"scene {spec!r}: expected key=value after ':', got {item!r}")
        k, v = (s.strip() for s in item.split("=", 1))
        out[k] = v
    return out


def _is_xml(spec: str) -> bool:
    return spec.lower().endswith(".xml")


def _is_mesh(spec: str) -> bool:
    return spec.lower().endswith(MESH_SUFFIXES)


def load_scene(spec, **params) -> Scene:
    """Build a scene from a built-in name (optionally ``name:key=value,...``), a Mitsuba 3 XML path,
    or a mesh file path (the ``mesh`` scene). Bad input raises :class:`LdbenchError` naming it.
    Exact duplicate triangles within a mesh are removed, with a line in ``scene.warnings``
    (:func:`ldbench.core.scene.without_duplicate_triangles`: every method and reference see them once)."""
    from .scene import without_duplicate_triangles

    return without_duplicate_triangles(_load_scene(spec, **params))


def _load_scene(spec, **params) -> Scene:
    """:func:`load_scene` before the duplicate triangles are removed."""
    spec = os.fspath(spec) if isinstance(spec, os.PathLike) else spec
    if not isinstance(spec, str) or not spec.strip():
        raise LdbenchError(f"scene must be a name or a file path, got {spec!r}")
    spec = spec.strip()
    from .scene_registry import registry

    if spec.split(":", 1)[0] in registry():
        if params or ":" in spec:
            given = ", ".join(params) or spec.split(":", 1)[1]
            raise LdbenchError(f"registered scene {spec.split(':', 1)[0]!r} takes no parameters (got {given})")
        return build_registered(spec)
    if spec in BUILDERS or (":" in spec and spec.split(":", 1)[0] in BUILDERS):
        name, _, inline = spec.partition(":")
        params = {**_parse_inline_params(inline, spec), **params}
        known = _builder_params(name)
        for k in params:
            if k not in known:
                raise LdbenchError(f"unknown parameter {k!r} for scene {name!r} "
                                   f"(parameters: {', '.join(known) or 'none'})")
        return BUILDERS[name](**params)
    if _is_xml(spec):
        from .mitsuba_xml import load_mitsuba_xml
        return load_mitsuba_xml(spec, **params)
    if _is_mesh(spec):
        for k in params:
            if k not in ("albedo",):
                raise LdbenchError(f"unknown parameter {k!r} for mesh scene {spec!r} (parameters: albedo)")
        return build_mesh(path=spec, **params)
    if os.path.exists(spec):
        raise LdbenchError(f"cannot tell what scene file {spec!r} is: expected a Mitsuba .xml or a mesh "
                           f"({', '.join(MESH_SUFFIXES)})")
    raise LdbenchError(f"unknown scene {spec!r} (built-in: {', '.join(BUILDERS)}; registered: "
                       f"{', '.join(registry())}; or a path to a Mitsuba .xml file or a "
                       f"{'/'.join(s[1:] for s in MESH_SUFFIXES)} mesh)")
