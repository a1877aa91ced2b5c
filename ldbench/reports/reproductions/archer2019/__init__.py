"""archer2019: Archer, Leach, Knowles, "Fast raycasting using a compound deep image for virtual point light
range determination" (CVM 2019), Tables 1–3 and the claims of §3.1 and §4 as data, one folder per table
(``table1``, ``table2``, ``table3``, ``layouts``: its :class:`~ldbench.reports.reproduce.Reproduction` and its
``suite.toml``; the engine is :mod:`ldbench.reports.reproduce`; the adapter is ``cdi-vpl``,
ldbench/methods/cdi_vpl). This package holds what Tables 1–3 share: the scenes, the ci scale, the set-up notes
and the paper's fields.

Scenes: ``atrium`` with 260,000 triangles stands for their Sponza Atrium ("approximately 280,000"), ``city``
with 7,000,000 triangles for Rungholt ("approximately 7 million"; ldbench/core/scenes/city.py, a
procedural town of gabled houses). Their GPU: a GTX 1060 (driver 390.25), 1920×1080.

What each of our rows times (``total_ms``, the sum of a frame's stages):

* Table 1 "Total": a whole ``indirect`` frame (CDI build, G-buffer, RSM, VPL buffer with the raycast, light
  grid, shading); the table's steps are that row's stage times (:data:`.table1.STEPS`: count + scan + fill =
  capture, sort, gbuffer, rsm, vpl, grid_*, shade). "Build VPL buffer" is also timed alone (a static
  CDI's raycast of 16,384 VPLs) for the 1 % claim.
* Table 2: a ``vpl_range`` frame on a 16² RSM: the CDI build plus a raycast of at most 1,536 rays.
* Table 3: a ``vpl_range`` frame on a static CDI: the raycast alone (or the random ranges).
"""
from __future__ import annotations

from typing import TypedDict

#: The stand-ins for the Sponza Atrium and Rungholt (scene parameters)
ATRIUM = {"triangles": 260000}
CITY = {"triangles": 7000000}

#: The ci scale of Tables 1–3: tiny, for llvmpipe
CI = {
    "size": "64x36", "spp": 16, "warmup": 0, "frames": 3,
    "params": {"cdi-vpl": {"resolution": 32, "rsm": 64}},
    "scene_params": {"atrium": {"triangles": 4000}, "city": {"triangles": 16000}},
}

#: The notes that open Tables 1–3: the scenes, the CDI, the settings that differ from the paper
SETUP_NOTES = (
    "Scenes: `atrium` (260,000 triangles) for the Sponza Atrium (~280,000), `city` (7,000,000) for Rungholt "
    "(~7 M): a procedural town of 1,024 gabled houses on 8 × 8 blocks (416 m across), docs/reference/methods/cdi_vpl.md.",
    "CDI: 169 deep images of 64², 13 × 13 stacks × slices of the upper hemisphere, linearised arrays; "
    "one-pass build (geometry-shader swizzle to the dominant axis, all directions in the fragment shader), "
    "or brute force (one raster per direction in its own view).",
    "Settings that differ from the paper: a procedural town for Rungholt; VPLs are every second RSM texel "
    "(Table 1) or every texel (Table 3), none chosen by mip level or discarded by size; diffuse, unshadowed "
    "lighting without the per-pixel VPL normalisation (theirs: Cook–Torrance); the light grid and the "
    "random-range hash are ours; stage times are GPU timer queries of our passes.",
)


class PaperFields(TypedDict):
    """The :class:`Reproduction` fields that every table of the paper shares."""

    paper: str
    hardware: str
    resolution: str
    paper_scene: str


# What every table of the paper shares: where it was measured, and on what.
PAPER = PaperFields(paper="archer2019", hardware="NVIDIA GeForce GTX 1060 (driver 390.25)",
                    resolution="1920x1080", paper_scene="Sponza Atrium (~280k triangles), Rungholt (~7 M)")

#: The order of the tables in `ldbench reproduce --list` (a table folder not named here follows, by name)
TABLES = ("table1", "table2", "table3", "layouts")
