"""The ``mesh`` scene: any mesh file in an open box (also what a ``.ply``/``.obj``/``.stl``/``.off`` path as the
scene builds), and :func:`object_in_box`, that box's layout, which registered ``object`` scenes share."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.meshio import box_parts, read_mesh
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import GREEN, RED, WHITE, SceneBuilder, SceneParams, part_mesh, rgb


@dataclass(frozen=True)
class MeshParams(SceneParams):
    path: str = param("", "the mesh file (.ply, .obj, .stl, .off)")
    albedo: tuple = rgb((0.8, 0.8, 0.8), "the mesh's diffuse albedo, linear RGB in [0, 1]")


class MeshInBox(SceneBuilder):
    """A mesh file (PLY/OBJ/STL/OFF) standing on the floor of an open box (e.g. the Stanford dragon).

    The mesh (all parts merged, loaded with trimesh, ``process=False``) is scaled uniformly so that its
    largest bounding-box side is 1 m, centred at x = z = 0 and put on the floor (min y = 0), with
    the diffuse ``albedo``. The box: floor and ceiling-less walls of x, z ∈ [-1.25, 1.25], walls 2 m
    high: back (white), left (red), right (green); front and top open. The scene is named after the file.
    Camera: (0, 0.9, 3.6) looking at (0, 0.5, 0), vertical fov 40°.
    Light: a spot at (0.9, 2.4, 1.8) aimed at (0, 0.35, 0), cutoff 45°, beam 33.75°, 12 W/sr.
    """

    name = "mesh"
    Params = MeshParams

    def build(self, p: MeshParams) -> Scene:
        if p.path.strip() == "":
            raise LdbenchError("scene 'mesh' needs the parameter 'path' (a .ply or .obj file)")
        v, f = read_mesh(p.path)
        name = Path(p.path).stem
        cam = Camera(origin=(0.0, 0.9, 3.6), target=(0.0, 0.5, 0.0), up=(0, 1, 0), fov_y=40.0)
        light = SpotLight(position=(0.9, 2.4, 1.8), target=(0.0, 0.35, 0.0), intensity=(12.0,) * 3,
                          cutoff_angle=45.0, up=(0.0, 1.0, 0.0))
        return Scene(name, object_in_box(name, v, f, p.albedo, p.path), cam, [light])


def object_in_box(name, v, f, albedo, path) -> list:
    """The mesh scene's layout: the object scaled to a largest side of 1 m, centred at x = z = 0 on the
    floor of the open 2.5 × 2 × 2.5 m box (floor and back wall white, left red, right green)."""
    lo, hi = v.min(0), v.max(0)
    ext = float((hi - lo).max())
    if not ext > 0:
        raise LdbenchError(f"cannot read mesh {path}: the mesh has zero extent")
    v = (v - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])) / ext
    room = box_parts((-1.25, 0, -1.25), (1.25, 2.0, 1.25), 1, skip=("+z", "+y"), inward=True)
    return [
        part_mesh(name, (v, f), albedo),
        part_mesh("floor", room["-y"], WHITE),
        part_mesh("back_wall", room["-z"], WHITE),
        part_mesh("left_wall", room["-x"], RED),
        part_mesh("right_wall", room["+x"], GREEN),
    ]
