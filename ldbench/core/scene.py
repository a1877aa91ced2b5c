"""The scene model shared by the GPU methods and the Mitsuba references.

A :class:`Scene` is triangle meshes with Lambertian albedo, one camera and spot/point lights, in the
conventions of docs/design.md: right-handed, y up, metres; triangles counter-clockwise from the front but
treated as two-sided everywhere; camera = look-at + vertical field of view; image row 0 at the top.
The *same* triangles go to the GPU and to Mitsuba, so analytic shapes are tessellated by the builders.

Matrices here are numpy float64, column-vector convention (``p_clip = P @ V @ p_world``); upload them
to GLSL transposed (``m.T.astype('f4').tobytes()``), as GLSL matrices are column-major.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import LdbenchError


#: The largest coordinate (vertices, camera, lights; world units) a scene may hold: the GPU computes in
#: float32, whose largest finite value is 3.4e38, and squares distances (3 · (2e18)² = 1.2e37 still
#: fits). A vertex at 1e39 is finite in float64 but infinite once uploaded.
MAX_COORDINATE = 1e18
#: The largest light intensity (W/sr, per channel): products with albedos and 1/distance² stay finite in
#: float32.
MAX_INTENSITY = 1e30


def _vec3(v, what: str, bound: float | None = None) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise LdbenchError(f"{what} must be 3 finite numbers, got {v!r}")
    if bound is not None and not np.all(np.abs(a) <= bound):
        raise LdbenchError(f"{what} {tuple(float(x) for x in a)} beyond ±{bound:g} (the GPU computes in float32)")
    return a


def _coordinates(v, what: str) -> np.ndarray:
    """``v`` as (N, 3) float32 after checking every value is finite and within :data:`MAX_COORDINATE`
    (checked before the cast, so that an overflow is one line, not a numpy warning and an infinity)."""
    a = np.asarray(v)
    a = (a if a.dtype == np.float32 else a.astype(np.float64, copy=False)).reshape(-1)  # no copy of float32
    if a.size and not np.abs(a).max() <= MAX_COORDINATE:  # a NaN maximum fails too
        ok = np.abs(a) <= MAX_COORDINATE
        raise LdbenchError(f"{what}: vertex coordinate {float(a[np.argmin(ok)]):g} is not finite or beyond "
                           f"±{MAX_COORDINATE:g} (the GPU computes in float32)")
    return np.ascontiguousarray(a, dtype=np.float32).reshape(-1, 3)


@dataclass(frozen=True, eq=False)
class Mesh:
    """One triangle mesh with a single Lambertian albedo (linear RGB in [0, 1]).

    ``opacity`` α ∈ [0, 1] is read only by the ``oit`` effect (ldbench/core/effects/oit.py: front-to-back
    "over" of every surface along the pixel ray); every other effect treats surfaces as opaque.
    """

    name: str
    vertices: np.ndarray  # (N, 3) float32, world space (transforms already applied)
    faces: np.ndarray  # (M, 3) int32 vertex indices
    albedo: tuple = (0.8, 0.8, 0.8)
    opacity: float = 1.0

    def __post_init__(self):
        v = _coordinates(self.vertices, f"mesh {self.name!r}")
        f = np.ascontiguousarray(self.faces, dtype=np.int32).reshape(-1, 3)
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise LdbenchError(f"mesh {self.name!r}: face index out of range")
        a = tuple(float(x) for x in _vec3(self.albedo, f"mesh {self.name!r} albedo"))
        if min(a) < 0 or max(a) > 1:
            raise LdbenchError(f"mesh {self.name!r}: albedo {a} outside [0, 1]")
        if isinstance(self.opacity, bool) or not isinstance(self.opacity, (int, float, np.floating, np.integer)):
            raise LdbenchError(f"mesh {self.name!r}: opacity must be a number in [0, 1], got {self.opacity!r}")
        alpha = float(self.opacity)
        if not 0.0 <= alpha <= 1.0:
            raise LdbenchError(f"mesh {self.name!r}: opacity {alpha} outside [0, 1]")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        object.__setattr__(self, "albedo", a)
        object.__setattr__(self, "opacity", alpha)


@dataclass(frozen=True)
class Camera:
    """Look-at pinhole camera; ``fov_y`` is the vertical field of view in degrees."""

    origin: tuple
    target: tuple
    up: tuple = (0.0, 1.0, 0.0)
    fov_y: float = 40.0

    def __post_init__(self):
        for k in ("origin", "target", "up"):
            object.__setattr__(self, k, tuple(float(x) for x in _vec3(getattr(self, k), f"camera {k}",
                                                                      MAX_COORDINATE)))
        if not 0.0 < self.fov_y < 180.0:
            raise LdbenchError(f"camera fov_y must be in (0, 180) degrees, got {self.fov_y}")

    def basis(self):
        """(right, up, forward) unit vectors in world space; forward points at the target."""
        o, t, u = (np.array(x) for x in (self.origin, self.target, self.up))
        fwd = t - o
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, u)
        n = np.linalg.norm(right)
        if n < 1e-9:
            raise LdbenchError("camera up vector is parallel to the viewing direction")
        right /= n
        return right, np.cross(right, fwd), fwd

    def view_matrix(self) -> np.ndarray:
        r, u, f = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ np.array(self.origin)
        return m

    def projection_matrix(self, aspect: float, near: float, far: float) -> np.ndarray:
        """OpenGL perspective projection (aspect = width / height)."""
        t = 1.0 / math.tan(math.radians(self.fov_y) / 2)
        m = np.zeros((4, 4))
        m[0, 0], m[1, 1] = t / aspect, t
        m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
        m[3, 2] = -1.0
        return m

    def primary_rays(self, width: int, height: int):
        """World-space rays through pixel centres, row 0 at the top: (origins, dirs) of shape (H*W, 3).

        This is the exact sampling a rasterized G-buffer without MSAA performs; the references use it.
        """
        r, u, f = self.basis()
        t = math.tan(math.radians(self.fov_y) / 2)
        aspect = width / height
        xs = ((np.arange(width) + 0.5) / width * 2 - 1) * t * aspect
        ys = (1 - (np.arange(height) + 0.5) / height * 2) * t
        X, Y = np.meshgrid(xs, ys)
        d = X[..., None] * r + Y[..., None] * u + f
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        d = d.reshape(-1, 3)
        return np.broadcast_to(np.array(self.origin), d.shape).copy(), d


@dataclass(frozen=True)
class SpotLight:
    """Mitsuba 3 ``spot`` emitter: intensity in W/sr (RGB), angles in degrees.

    Fall-off (Mitsuba 3 ``spot``): 1 inside ``beam_width``, linear in angle down to 0 at ``cutoff_angle``.
    A point light is ``cutoff_angle = 180`` (and ``beam_width = 180``).
    """

    position: tuple
    target: tuple
    intensity: tuple = (10.0, 10.0, 10.0)
    cutoff_angle: float = 20.0
    beam_width: float | None = None  # Mitsuba's default: 3/4 of cutoff_angle
    up: tuple = (0.0, 1.0, 0.0)

    def __post_init__(self):
        for k in ("position", "target", "intensity", "up"):
            bound = MAX_INTENSITY if k == "intensity" else MAX_COORDINATE
            object.__setattr__(self, k, tuple(float(x) for x in _vec3(getattr(self, k), f"light {k}", bound)))
        if min(self.intensity) < 0:
            raise LdbenchError(f"light intensity {self.intensity} is negative (W/sr per channel, >= 0)")
        if not 0.0 < self.cutoff_angle <= 180.0:
            raise LdbenchError(f"light cutoff_angle must be in (0, 180], got {self.cutoff_angle}")
        bw = self.cutoff_angle * 0.75 if self.beam_width is None else float(self.beam_width)
        if self.cutoff_angle >= 180.0:
            bw = 180.0
        if not 0.0 <= bw <= self.cutoff_angle:
            raise LdbenchError(f"light beam_width must be in [0, cutoff_angle], got {bw}")
        object.__setattr__(self, "beam_width", bw)

    @property
    def is_point(self) -> bool:
        return self.cutoff_angle >= 180.0

    def direction(self) -> np.ndarray:
        d = np.array(self.target) - np.array(self.position)
        n = np.linalg.norm(d)
        if n < 1e-12:
            raise LdbenchError("light target equals its position")
        return d / n

    def falloff(self, cos_theta: np.ndarray) -> np.ndarray:
        """Mitsuba 3 spot fall-off as a function of the cosine to the spot axis (numpy reference)."""
        if self.is_point:
            return np.ones_like(cos_theta)
        theta = np.arccos(np.clip(cos_theta, -1, 1))
        assert self.beam_width is not None  # __post_init__ replaced the None default by its value
        cut, beam = math.radians(self.cutoff_angle), math.radians(self.beam_width)
        trans = (cut - theta) / max(cut - beam, 1e-12)
        v = np.where(theta <= beam, 1.0, trans)
        return np.where(theta < cut, v, 0.0)


@dataclass(eq=False)
class Scene:
    """Meshes + camera + lights. ``params`` records how a builder was called (part of the hash)."""

    name: str
    meshes: list
    camera: Camera
    lights: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    source: str = "builtin"  # "builtin" or the XML path
    warnings: list = field(default_factory=list)

    def __post_init__(self):
        if not self.meshes or self.triangle_count == 0:
            raise LdbenchError(f"scene {self.name!r} has no triangles")

    @property
    def triangle_count(self) -> int:
        return int(sum(len(m.faces) for m in self.meshes))

    def bounds(self):
        """Axis-aligned bounds (lo, hi) of all vertices, float64."""
        allv = np.concatenate([m.vertices for m in self.meshes])
        return allv.min(0).astype(np.float64), allv.max(0).astype(np.float64)

    def diagonal(self) -> float:
        lo, hi = self.bounds()
        return float(np.linalg.norm(hi - lo))

    def merged(self):
        """All meshes as one: (vertices (N,3) f4, faces (M,3) i4, material id per face (M,) i4, albedos (K,3) f4)."""
        vs, fs, mids, off = [], [], [], 0
        for i, m in enumerate(self.meshes):
            vs.append(m.vertices)
            fs.append(m.faces + off)
            mids.append(np.full(len(m.faces), i, np.int32))
            off += len(m.vertices)
        albedo = np.array([m.albedo for m in self.meshes], np.float32)
        return np.concatenate(vs), np.concatenate(fs).astype(np.int32), np.concatenate(mids), albedo

    def content_hash(self) -> str:
        """SHA-256 over geometry, materials, camera and lights (keys the reference cache).

        Opacities enter only when some mesh has opacity < 1, so scenes of opaque surfaces keep the
        hashes (and cached references) they had before opacity existed."""
        h = hashlib.sha256()
        for m in self.meshes:
            h.update(m.vertices.tobytes())
            h.update(m.faces.tobytes())
            h.update(np.array(m.albedo, np.float64).tobytes())
        if any(m.opacity < 1.0 for m in self.meshes):
            h.update(np.array([m.opacity for m in self.meshes], np.float64).tobytes())
        meta = {
            "camera": [self.camera.origin, self.camera.target, self.camera.up, self.camera.fov_y],
            "lights": [[l.position, l.target, l.intensity, l.cutoff_angle, l.beam_width, l.up]
                       for l in self.lights],
        }
        h.update(json.dumps(meta, sort_keys=True).encode())
        return h.hexdigest()[:16]


def duplicate_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(M,) bool: the faces that repeat an earlier face of the same mesh exactly — the same three vertex
    positions (bit for bit, −0 = +0), in any order and either winding, through any vertex indices."""
    faces = np.asarray(faces).reshape(-1, 3)
    if len(faces) < 2:
        return np.zeros(len(faces), bool)
    bits = (np.asarray(vertices, np.float32).reshape(-1, 3) + np.float32(0.0)).view(np.uint32).astype(np.uint64)
    vid, _, _ = _equal_keys([(bits[:, 0] << np.uint64(32)) | bits[:, 1], bits[:, 2]])  # one id per position
    t = np.sort(vid[faces], axis=1)
    n = int(vid.max()) + 1
    keys = [(t[:, 0] * n + t[:, 1]) * n + t[:, 2]] if n < 2_000_000 else [t[:, 0] * n + t[:, 1], t[:, 2]]
    _, order, first = _equal_keys(keys)
    dup = np.ones(len(faces), bool)
    dup[order[first]] = False  # a stable sort: each group's first is its earliest face
    return dup


def _equal_keys(keys: list):
    """Rows (one value per key array) grouped by value: (group id per row, the stable lexicographic order,
    and per sorted position whether it starts a group)."""
    order = np.argsort(keys[0], kind="stable") if len(keys) == 1 else np.lexsort(keys[::-1])
    first = np.ones(len(order), bool)
    first[1:] = np.logical_or.reduce([k[order][1:] != k[order][:-1] for k in keys])
    gid = np.empty(len(order), np.int64)
    gid[order] = np.cumsum(first) - 1
    return gid, order, first


def without_duplicate_triangles(scene: "Scene") -> "Scene":
    """``scene`` with exact duplicate triangles removed within each mesh (:func:`duplicate_faces`; the
    first copy kept, the order kept), and one line in ``scene.warnings`` saying how many.

    One rule for coincident copies of a triangle, applied once where a scene is loaded, so that every
    method and every reference see the same triangles: a mesh file that lists a triangle twice (scan
    meshes do: the low-resolution Stanford bunny has 31) describes one surface. Without it, per-pixel
    lists store both copies (an OIT composite applies the opacity twice), depth peeling keeps one, and
    the OIT reference (which finds one hit per surface along a ray) counts it once. Copies in *different*
    meshes stay: they are distinct surfaces (materials), ordered by the effect's tie rule."""
    meshes, removed = [], []
    for m in scene.meshes:
        dup = duplicate_faces(m.vertices, m.faces)
        if dup.any():
            removed.append((m.name, int(dup.sum())))
            m = replace(m, faces=m.faces[~dup])
        meshes.append(m)
    if not removed:
        return scene
    n = sum(k for _, k in removed)
    where = ", ".join(f"{name!r}: {k}" for name, k in removed[:3]) + (", ..." if len(removed) > 3 else "")
    line = (f"scene {scene.name!r}: {n} duplicate triangle{'s' if n != 1 else ''} removed (exact copies within "
            f"one mesh; {where}): every method and the reference see each triangle once")
    return replace(scene, meshes=meshes, warnings=[*scene.warnings, line])
