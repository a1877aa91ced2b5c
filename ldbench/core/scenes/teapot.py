"""The ``teapot`` scene: a closed, teapot-like solid for order-independent transparency."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldbench.core.meshio import grid_faces
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import SceneBuilder, SceneParams, part_mesh

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


@dataclass(frozen=True)
class TeapotParams(SceneParams):
    segments: int = param(48, "vertices around every ring: about 4.5 · segments² triangles", lo=8, hi=1024)
    opacity: float = param(0.5, "α of every part for the oit effect", lo=0.0, hi=1.0)


class Teapot(SceneBuilder):
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

    name = "teapot"
    Params = TeapotParams

    def build(self, p: TeapotParams) -> Scene:
        seg, opacity = p.segments, p.opacity
        body = _catmull_rom(_TEAPOT_BODY, max(2, round(seg / (len(_TEAPOT_BODY) - 1))))
        parts = {"body": _revolved(body, seg)}
        along = max(2, round(seg / 2 / (len(_TEAPOT_SPOUT) - 1)))
        for name, ctl in (("spout", _TEAPOT_SPOUT), ("handle", _TEAPOT_HANDLE)):
            c = _catmull_rom(np.asarray(ctl)[:, :2], along)
            r = np.interp(np.linspace(0, 1, len(c)), np.linspace(0, 1, len(ctl)), np.asarray(ctl)[:, 2])
            parts[name] = _tube(np.concatenate([c, np.zeros((len(c), 1))], 1), r, seg)
        albedo = (0.80, 0.30, 0.10)
        meshes = [part_mesh(k, (v * TEAPOT_SCALE, f), albedo, opacity) for k, (v, f) in parts.items()]
        cam = Camera(origin=(0.35, 0.85, 2.1), target=(0.07, 0.18, 0.0), up=(0, 1, 0), fov_y=35.0)
        light = SpotLight(position=(1.0, 2.2, 1.6), target=(0.07, 0.2, 0.0), intensity=(8.0,) * 3,
                          cutoff_angle=40.0, beam_width=30.0, up=(0.0, 1.0, 0.0))
        return Scene("teapot", meshes, cam, [light])


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

