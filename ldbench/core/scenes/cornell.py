"""The ``cornell`` scene: the Cornell box with its two blocks."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.meshio import box, box_parts, rot_y
from ldbench.core.params import param
from ldbench.core.scene import Camera, Scene, SpotLight

from .base import GREEN, RED, WHITE, SceneBuilder, SceneParams, part_mesh


@dataclass(frozen=True)
class CornellParams(SceneParams):
    subdivide: int = param(0, "every quad split into (s+1)² cells: 30 (s+1)² triangles", lo=0, hi=128)
    blocks: bool = param(True, "the short and the tall block; false: the empty box (10 (s+1)² triangles)")


class Cornell(SceneBuilder):
    """The Cornell box with the short and the tall block, normalised to a 2 m box, lit by a spot light.

    Geometry (metres): x ∈ [-1, 1] (red wall at x = -1 on the left, green wall at x = +1 on the
    right), floor y = 0, ceiling y = 2, back wall z = -1, front (z = +1) open. The blocks are those
    of Bitterli's / PBRT's Cornell box (short block 0.6 m high at (0.33, 0.37), tall block 1.2 m high
    at (-0.34, -0.29), rotated about y); their hidden bottom faces are left out (``blocks = false``: the
    empty box, niessner2010 §7's). 30 triangles;
    ``subdivide`` = s splits every quad into (s+1)² cells, 30 (s+1)² triangles.
    Camera: (0, 1, 3.9) looking at (0, 1, 0), vertical fov 39.3077° (the classic Cornell camera's
    distance ratio). Light: a spot at (0, 1.95, 0) pointing straight down, cutoff 60°, beam 45°,
    intensity 10 W/sr (white).
    """

    name = "cornell"
    Params = CornellParams

    def build(self, p: CornellParams) -> Scene:
        n = p.subdivide + 1
        walls = box_parts((-1, 0, -1), (1, 2, 1), n, skip=("+z",), inward=True)
        meshes = [
            part_mesh("floor", walls["-y"], WHITE),
            part_mesh("ceiling", walls["+y"], WHITE),
            part_mesh("back_wall", walls["-z"], WHITE),
            part_mesh("left_wall", walls["-x"], RED),
            part_mesh("right_wall", walls["+x"], GREEN),
        ]
        # (centre x, centre z, size x, height, size z, rotation about y in degrees): Bitterli's blocks.
        blocks = {"short_block": (0.328631, 0.374592, 0.595, 0.6, 0.604, 73.36),
                  "tall_block": (-0.335439, -0.291415, 0.607, 1.2, 0.598, 19.19)}
        for name, (cx, cz, sx, h, sz, ang) in (blocks.items() if p.blocks else ()):
            v, f = box((-sx / 2, 0, -sz / 2), (sx / 2, h, sz / 2), n, skip=("-y",))
            v = v @ rot_y(ang).T + np.array([cx, 0, cz])
            meshes.append(part_mesh(name, (v, f), WHITE))
        cam = Camera(origin=(0.0, 1.0, 3.9), target=(0.0, 1.0, 0.0), up=(0, 1, 0), fov_y=39.3077)
        light = SpotLight(position=(0.0, 1.95, 0.0), target=(0.0, 0.0, 0.0), intensity=(10.0, 10.0, 10.0),
                          cutoff_angle=60.0, beam_width=45.0, up=(0.0, 0.0, -1.0))
        return Scene("cornell", meshes, cam, [light])
