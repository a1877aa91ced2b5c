"""Mesh file IO and triangle primitives, shared by the scene builders and the Mitsuba XML loader.

A *part* is ``(vertices (N, 3) float64, faces (M, 3) int64)``; faces are counter-clockwise seen from
the front. Everything is vectorised numpy and deterministic. Mesh files are read with trimesh
(``process=False``, so the file's triangles are kept one for one); MTL files only for their ``Kd``.
The analytic Mitsuba shapes (``rectangle``, ``cube``, ``disk``, ``cylinder``, ``sphere``) are tessellated here in
their local frames, so the GPU and the reference render the same triangles.
"""
from __future__ import annotations

import math
import os
import re

import numpy as np

from .errors import LdbenchError

# Heavy: trimesh (0.4 s) is imported by the functions that read or build meshes, so importing this module (every scene
# module does) stays light.

DISK_SEGMENTS = 64
SPHERE_SUBDIVISIONS = 4  # icosphere: 20 · 4^4 = 5120 triangles


# ---------------------------------------------------------------------------------------------------
# files

def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices float64, faces int64) of a mesh file, via trimesh (scenes merged, ``process=False``);
    vertices that no face uses are dropped (as Mitsuba's OBJ loader does), so bounds are the surface's.

    Any failure is ``LdbenchError("cannot read mesh <path>: <reason>")``.
    """
    import trimesh

    path = str(path)
    if not os.path.isfile(path):
        raise LdbenchError(f"cannot read mesh {path}: no such file")
    obj = path.lower().endswith(".obj")
    if obj:
        _check_obj_indices(path)
    try:
        m = trimesh.load(path, force="mesh", process=False)
        if not isinstance(m, trimesh.Trimesh):  # force="mesh" merges a scene into one; anything else has no faces
            raise LdbenchError(f"cannot read mesh {path}: not a triangle mesh")
        v = np.asarray(m.vertices, np.float64).reshape(-1, 3)
        f = np.asarray(m.faces, np.int64).reshape(-1, 3)
    except LdbenchError:
        raise
    except Exception as e:  # trimesh raises many types for bad files
        if obj:
            _check_obj_indices(path, full=True)  # an index out of range: name its line
        msg = " ".join(str(e).split()) or type(e).__name__
        raise LdbenchError(f"cannot read mesh {path}: {msg}") from None
    if len(f) == 0:
        raise LdbenchError(f"cannot read mesh {path}: no triangles in the file")
    if not np.all(np.isfinite(v)):
        raise LdbenchError(f"cannot read mesh {path}: non-finite vertex coordinates")
    if f.min() < 0 or f.max() >= len(v):
        if obj:
            _check_obj_indices(path, full=True)
        raise LdbenchError(f"cannot read mesh {path}: face index out of range")
    used, f = np.unique(f, return_inverse=True)  # drop vertices no face uses (scans often have them)
    return v[used], f.reshape(-1, 3)


#: An OBJ face line with an index 0 in any slot (``f 0 1 2``, ``f 1/0 2/1 3/1``): OBJ counts from 1 (negative
#: indices count back from the latest vertex), and trimesh reads 0 as -1, the last vertex, without a word.
_OBJ_ZERO = re.compile(rb"^[ \t]*f[ \t][^\n#]*?(?<=[ \t/])[+-]?0+(?=[ \t/\r\n#]|$)", re.M)
#: The face lines (comments cut) and a zero index among them: two C-speed passes (a line-by-line search is 3x
#: slower on a 66k-face OBJ); the line is found with :data:`_OBJ_ZERO` only when there is one.
_OBJ_FACES = re.compile(rb"^[ \t]*f[ \t][^\n#]*", re.M)
_ZERO_INDEX = re.compile(rb"[ \t/][+-]?0+(?=[ \t/\r\n]|$)", re.M)
#: A negative (relative) vertex index: OBJ counts it back from the latest vertex, trimesh from the file's last.
_NEGATIVE_INDEX = re.compile(rb"[ \t]-\d")


def _check_obj_indices(path: str, full: bool = False) -> None:
    """Refuse an OBJ face that names vertex 0 (one regular-expression pass, run on every OBJ), a relative
    (negative) index where vertices follow it (trimesh counts it from the end of the file, not from the
    latest vertex: other triangles, without a word) and, with ``full`` (a file trimesh could not index), a
    vertex before the first or after the last: ``LdbenchError`` naming ``path:line``. Returns when nothing
    is wrong (then the caller says why it failed)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as e:
        raise LdbenchError(f"cannot read mesh {path}: {e.strerror or e}") from None
    faces = b"\n".join(_OBJ_FACES.findall(data))
    m = _ZERO_INDEX.search(faces) and _OBJ_ZERO.search(data)
    if m:
        line = data.count(b"\n", 0, m.start()) + 1
        raise LdbenchError(f"cannot read mesh {path}:{line}: face index 0 (OBJ indices start at 1; negative ones "
                           f"count back from the latest vertex)")
    if not (full or _NEGATIVE_INDEX.search(faces)):
        return
    total = len(re.findall(rb"(?m)^[ \t]*v[ \t]", data))
    seen, relative = 0, 0  # vertices so far; the line of the first face with a relative index
    for n, raw in enumerate(data.splitlines(), 1):
        parts = raw.split(b"#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == b"v":
            seen += 1
            if relative:
                raise LdbenchError(f"cannot read mesh {path}:{relative}: a relative (negative) face index with "
                                   f"vertices after it (line {n}), which ldbench's OBJ reader would count from "
                                   "the file's last vertex: write positive indices")
        elif parts[0] == b"f":
            for tok in parts[1:]:
                try:
                    i = int(tok.split(b"/")[0])
                except ValueError:
                    raise LdbenchError(f"cannot read mesh {path}:{n}: face vertex {tok.decode(errors='replace')!r} "
                                       f"is not an index") from None
                if not (1 <= i <= total or -seen <= i <= -1):
                    raise LdbenchError(f"cannot read mesh {path}:{n}: face index {i} out of range (the file has "
                                       f"{total} vertices{f', {seen} before this line' if i < 0 else ''})")
                if i < 0 and not relative:
                    relative = n


def read_mtl(path) -> dict[str, tuple]:
    """``{material name: Kd}`` of a Wavefront MTL file (linear RGB as written; other statements ignored).

    A material without ``Kd`` is left out. Any failure is ``LdbenchError("cannot read materials ...")``.
    """
    path = str(path)
    out, name = {}, None
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            for n, line in enumerate(fh, 1):
                parts = line.split("#", 1)[0].split()
                if not parts:
                    continue
                if parts[0] == "newmtl":
                    name = " ".join(parts[1:])
                elif parts[0] == "Kd" and name is not None:
                    kd = tuple(float(x) for x in parts[1:4])
                    if len(kd) != 3 or not all(math.isfinite(x) for x in kd):
                        raise ValueError(f"line {n}: Kd needs 3 numbers")
                    out[name] = kd
    except OSError as e:
        raise LdbenchError(f"cannot read materials {path}: {e.strerror or e}") from None
    except ValueError as e:
        raise LdbenchError(f"cannot read materials {path}: {e}") from None
    return out


# ---------------------------------------------------------------------------------------------------
# primitives

def grid_faces(rows: int, cols: int, wrap: bool = False) -> np.ndarray:
    """Faces of a rows × cols vertex grid (vertex (r, c) = r * cols + c).

    Each cell gives (a_c, b_c, b_c+1), (a_c, b_c+1, a_c+1) with a = row r, b = row r + 1, so the
    front normal is (row direction) × (column direction). ``wrap`` closes the columns (tubes).
    """
    ncell = cols if wrap else cols - 1
    r = np.arange(rows - 1)[:, None]
    c = np.arange(ncell)[None, :]
    c1 = (c + 1) % cols
    a0, a1 = r * cols + c, r * cols + c1
    b0, b1 = (r + 1) * cols + c, (r + 1) * cols + c1
    f = np.stack([np.stack([a0, b0, b1], -1), np.stack([a0, b1, a1], -1)], -2)
    return f.reshape(-1, 3)


def quad(p0, a, b, n: int = 1):
    """Parallelogram p0 + s a + t b (s, t in [0, 1]) split into n × n cells; front normal a × b."""
    p0, a, b = (np.asarray(x, np.float64) for x in (p0, a, b))
    s = np.linspace(0.0, 1.0, n + 1)
    v = p0 + s[:, None, None] * a + s[None, :, None] * b
    return v.reshape(-1, 3), grid_faces(n + 1, n + 1)


def merge(parts):
    vs, fs, off = [], [], 0
    for v, f in parts:
        vs.append(v)
        fs.append(f + off)
        off += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def box_parts(lo, hi, n: int = 1, skip=(), inward: bool = False):
    """Faces of the axis-aligned box [lo, hi], keyed '+x', '-x', '+y', '-y', '+z', '-z'.

    Normals point out of the box (into it with ``inward``); faces named in ``skip`` are left out.
    """
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    X, Y, Z = np.array([x1 - x0, 0, 0]), np.array([0, y1 - y0, 0]), np.array([0, 0, z1 - z0])
    faces = {
        "+x": ((x1, y0, z0), Y, Z), "-x": ((x0, y0, z0), Z, Y),
        "+y": ((x0, y1, z0), Z, X), "-y": ((x0, y0, z0), X, Z),
        "+z": ((x0, y0, z1), X, Y), "-z": ((x0, y0, z0), Y, X),
    }
    out = {}
    for k, (p, a, b) in faces.items():
        if k in skip:
            continue
        out[k] = quad(p, b, a, n) if inward else quad(p, a, b, n)
    return out


def box(lo, hi, n: int = 1, skip=()):
    return merge(box_parts(lo, hi, n, skip).values())


def rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rotation(axis, deg: float) -> np.ndarray:
    """3 × 3 right-handed rotation by ``deg`` degrees about ``axis`` (normalised here)."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    t = math.radians(deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * (K @ K)


def instances(template, offsets):
    """Copies of a template part translated by each offset (vectorised)."""
    v, f = template
    offsets = np.asarray(offsets, np.float64).reshape(-1, 3)
    k = len(offsets)
    vv = (v[None] + offsets[:, None]).reshape(-1, 3)
    ff = (f[None] + (np.arange(k) * len(v))[:, None, None]).reshape(-1, 3)
    return vv, ff


def cylinder(radius: float, y0: float, y1: float, around: int, rings: int):
    """Open cylinder side around the y axis, outward normals: around × rings × 2 triangles."""
    phi = np.arange(around) * (2 * math.pi / around)
    y = np.linspace(y0, y1, rings + 1)
    v = np.empty((rings + 1, around, 3))
    v[..., 0] = radius * np.cos(phi)
    v[..., 1] = y[:, None]
    v[..., 2] = radius * np.sin(phi)
    return v.reshape(-1, 3), grid_faces(rings + 1, around, wrap=True)


def half_ring(r_in: float, r_out: float, depth: float, segs: int):
    """Arch: half annulus in the xy plane (angles 0..π about the origin), extruded over z ∈ ±depth/2.

    Four surfaces (intrados, extrados, front, back), normals outwards: 8 × segs triangles.
    """
    th = np.linspace(0.0, math.pi, segs + 1)
    c, s = np.cos(th), np.sin(th)

    def ring(r, z):
        return np.stack([r * c, r * s, np.full_like(c, z)], -1)

    A, B = ring(r_in, depth / 2), ring(r_out, depth / 2)  # front inner / outer
    C, D = ring(r_in, -depth / 2), ring(r_out, -depth / 2)  # back inner / outer
    g = grid_faces(2, segs + 1)
    return merge([(np.concatenate([A, B]), g),   # front (+z)
                   (np.concatenate([D, C]), g),   # back (-z)
                   (np.concatenate([B, D]), g),   # extrados (outwards)
                   (np.concatenate([C, A]), g)])  # intrados (towards the opening)


def rectangle():
    """Mitsuba's ``rectangle``: [-1, 1]² in the plane z = 0, front +z, 2 triangles."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
    return v, np.array([[0, 1, 2], [0, 2, 3]], np.int64)


def disk(segments: int = DISK_SEGMENTS):
    """Mitsuba's ``disk``: the unit disk in z = 0 as a ``segments``-gon fan, front +z."""
    phi = np.arange(segments) * (2 * math.pi / segments)
    v = np.concatenate([[[0.0, 0.0, 0.0]], np.stack([np.cos(phi), np.sin(phi), 0 * phi], -1)])
    k = np.arange(segments)
    return v, np.stack([np.zeros_like(k), 1 + k, 1 + (k + 1) % segments], -1)


def tube(segments: int = DISK_SEGMENTS):
    """Mitsuba's ``cylinder``: the open unit tube (radius 1) around +z from z = 0 to 1 as a ``segments``-gon
    prism side (no caps, as Mitsuba's), outward normals: 2 · segments triangles."""
    v, f = cylinder(1.0, 0.0, 1.0, segments, 1)
    return v @ np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]).T, f  # +90° about x: y axis -> z axis


def icosphere(subdivisions: int = SPHERE_SUBDIVISIONS):
    """The unit sphere as an icosphere (20 · 4^subdivisions triangles, vertices on the sphere), outwards."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    return np.asarray(ico.vertices, np.float64), np.asarray(ico.faces, np.int64)
