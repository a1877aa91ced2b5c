"""archer2019-table2: the CDI build time for 8 to 128 directions (Table 2, §4); one pass against brute force; the
CDI's memory. Its suite is ``suite.toml`` beside this file; the paper:
:mod:`ldbench.reports.reproductions.archer2019`."""
from __future__ import annotations

from typing import Any

from ldbench.reports.reproduce import Claim, Reproduction
from ldbench.reports.reproductions.archer2019 import ATRIUM, CI, CITY, PAPER, SETUP_NOTES

_TWENTY_TO_HUNDRED = ("the words' 20–100×, widened to the paper's own largest measurement that they summarise, "
                      "2295.8 / 22.1 = 104× (Rungholt)")


def _little(published: str, r: float) -> str:
    """The window of a 'little overhead / difference' claim with a published growth r."""
    return (f"'little overhead/difference' with the paper's own {published}: no faster than without the extra "
            f"directions (1×) and at most twice the published growth, 1 + 2 × {r - 1:.2f} = {1 + 2 * (r - 1):.2f}× "
            "(the paper's 'scales linearly' is affine: a fixed raster cost plus a small per-direction cost)")


DIRECTIONS = (8, 16, 32, 64, 128)

_T2_ROWS: list[dict[str, Any]] = []
for scene, sp, name, pub in (("atrium", ATRIUM, "Atrium", (1.5, 1.8, 2.0, 3.2, 4.7)),
                             ("city", CITY, "Rungholt", (18.0, 18.4, 18.6, 19.7, 21.3))):
    key = "atrium" if scene == "atrium" else "rungholt"
    for n, t in zip(DIRECTIONS, pub):
        _T2_ROWS.append({"id": f"{key}-{n}", "label": f"Table 2, {n} directions, {name}",
                         "paper_setup": f"{name}, {n} deep images of 64², one pass",
                         "match": {"scene": scene, "scene_params": sp, "method": "cdi-vpl", "effect": "vpl_range",
                                   "params": {"directions": n, "build": "one_pass", "cdi": "frame"}},
                         "time_ms": t})
    _T2_ROWS += [
        {"id": f"{key}-169", "label": f"169 directions, one pass, {name} (§4)",
         "paper_setup": f"{name}, 169 × 64², one pass (capture + sort, Table 1)",
         "match": {"scene": scene, "scene_params": sp, "method": "cdi-vpl", "effect": "vpl_range",
                   "params": {"directions": 169, "build": "one_pass", "cdi": "frame"}},
         "time_ms": 5.5 if scene == "atrium" else 22.1},
        {"id": f"{key}-brute", "label": f"169 directions, brute force, {name} (§4)",
         "paper_setup": f"{name}, one raster per direction",
         "match": {"scene": scene, "scene_params": sp, "method": "cdi-vpl", "effect": "vpl_range",
                   "params": {"directions": 169, "build": "brute_force"}},
         "time_ms": 121.3 if scene == "atrium" else 2295.8},
        *([{"id": "atrium-instanced", "label": "169 directions, instanced per-direction raster, Atrium",
            "paper_setup": "not in the paper (the ldm adapter's build: one instanced draw)",
            "match": {"scene": scene, "scene_params": sp, "method": "cdi-vpl", "effect": "vpl_range",
                      "params": {"directions": 169, "build": "instanced"}}}] if scene == "atrium" else []),
        {"id": f"{key}-memory", "label": f"CDI memory, {name} (§4)",
         "paper_setup": f"{name}, 169 × 64² CDI",
         "match": {"scene": scene, "scene_params": sp, "method": "cdi-vpl", "effect": "vpl_range",
                   "params": {"directions": 169, "cdi": "static"}},
         "memory_mb": None, "structure_mb": 18.0},
    ]

def _size_reason(v) -> str:
    """Why the two CDIs differ in size: their fragments (the rows' counter), per texel of 169 maps of 64²."""
    fr, fa = v("rungholt-memory", "counter:fragments"), v("atrium-memory", "counter:fragments")
    texels = 169 * 64 * 64
    return (f"a CDI's size follows its fragments: {fr / 1e6:.2f} M in our city stand-in against {fa / 1e6:.2f} M in "
            f"the atrium (counter fragments), lists of {fr / texels:.2f} against {fa / texels:.2f} fragments a texel "
            f"over the 169 maps of 64²: with {CITY['triangles'] / ATRIUM['triangles']:.0f}× the triangles, our city is "
            f"shallower along these directions, where Rungholt's lists are 'only slightly longer' than the Atrium's "
            f"(§4)")


REPRODUCTION = Reproduction(
    **PAPER,
    key="archer2019-table2",
    title="CDI build time for 8 to 128 directions (Table 2); one pass vs brute force; CDI memory",
    source="Table 2 and §4",
    rows=tuple(_T2_ROWS),
    claims=(
        Claim("The one-pass build is 20–100× faster than brute force (Atrium)", "atrium-brute", "atrium-169",
              ("time_ms",), "ratio", ratio=(20.0, 104.0), where="§4 '20× to 100× faster than a brute force approach'",
              published="121.3 / 5.5 ms = 22×", why=_TWENTY_TO_HUNDRED,
              reason="the one-pass build has a floor that does not follow the directions: its Table 2 rows grow "
                     "little from 8 to 169 directions, the cost of its one hardware raster of the 260k "
                     "triangles, which this GPU's weak raster makes slow (docs/reference/methods/gbuffer.md), "
                     "while the brute force's 169 small rasters gain more over the paper's GTX 1060 than the one "
                     "pass does (both rows beside the published ones)"),
        Claim("The one-pass build is 20–100× faster than brute force (Rungholt)", "rungholt-brute", "rungholt-169",
              ("time_ms",), "ratio", ratio=(20.0, 104.0), where="§4 '20× to 100× faster than a brute force approach'",
              published="2295.8 / 22.1 ms = 104×", why=_TWENTY_TO_HUNDRED),
        Claim("Little overhead for many directions: 16× the directions, 1–5.3× the time (Atrium, 8 → 128)",
              "atrium-128", "atrium-8", ("time_ms",), "ratio", ratio=(1.0, 1.0 + 2 * (4.7 / 1.5 - 1)),
              where="Table 2; §4 'There is little overhead for computing many directions'",
              published="4.7 / 1.5 ms = 3.1×", why=_little("4.7 / 1.5 = 3.13×", 4.7 / 1.5)),
        Claim("…and 64 → 128 directions, 1–1.94× the time (Atrium)", "atrium-128", "atrium-64",
              ("time_ms",), "ratio", ratio=(1.0, 1.0 + 2 * (4.7 / 3.2 - 1)), where="Table 2",
              published="4.7 / 3.2 ms = 1.47×", why=_little("4.7 / 3.2 = 1.47×", 4.7 / 3.2)),
        Claim("Little difference in build time with directions (Rungholt, 8 → 128: 1–1.37×)", "rungholt-128",
              "rungholt-8", ("time_ms",), "ratio", ratio=(1.0, 1.0 + 2 * (21.3 / 18.0 - 1)),
              where="Table 2; §4 'There is little difference in performance for the Rungholt scene'",
              published="21.3 / 18.0 ms = 1.18×", why=_little("21.3 / 18.0 = 1.18×", 21.3 / 18.0)),
        Claim("CDIs of the two scenes are about the same size (18 MB)", "rungholt-memory", "atrium-memory",
              ("structure_mb",), "ratio", ratio=(1 / 1.2, 1.2), where="§4 'approximately the same size, at 18 MB'",
              published="18 MB each",
              why="'approximately the same size' with both printed as 18 MB: within ±20 %, the tolerance the "
                  "paper's own 'no more than 10 % slower' needed for its Table 3 (1.15–1.20×); structure memory "
                  "(the CDI's own buffers, the paper's 18 MB), not every allocation",
              # Paper scale only: §4 says so of scenes where "Rungholt has more than 20× the number of
              # triangles" in 169 CDIs of 64², because its "fragment list lengths ... are typically only
              # slightly longer"; ci compares 16,000 against 4,000 triangles (4×) in maps of 32².
              scales=("paper",), reason=_size_reason),
    ),
    scales={"paper": {}, "ci": CI},
    notes=SETUP_NOTES + (
        "A Table 2 row times a vpl_range frame on a 16² RSM: the CDI build (count, scan, fill, sort) and a raycast "
        "of at most 1,536 rays (its own stage, 'raycast', in stage_ms; microseconds on a GPU).",
        "The memory rows build the CDI once and release the scene's triangles (cdi = 'static'): memory_bytes is "
        "then the CDI (offsets, depths, scan sums, axes) plus the outputs of ≤ 256 VPLs. MB read as 2^20 bytes.",
        "The paper's 'linear in directions' is an affine growth (a fixed raster cost plus a per-direction cost); "
        "the claims test its size (little overhead: at most twice the published growth), not only that it is "
        "no worse than linear.",
        "Memory claims use structure memory (structure_bytes: the CDI's offsets, depths, scan sums, counters and "
        "layer transforms), the paper's 18 MB; memory (every allocation) adds the VPL outputs and axes.",
    ),
)
