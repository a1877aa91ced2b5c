"""archer2019-layouts: the one-pass build's redundant fragments (up to 25 % more CDI memory), and linearised arrays
against linked lists (§3.1). Its suite is ``suite.toml`` beside this file; the paper:
:mod:`ldbench.reports.reproductions.archer2019`."""
from __future__ import annotations

from ldbench.reports.reproduce import Claim, Reproduction

_LAYOUT_RAYS = {"scene": "atrium", "method": "ldm", "effect": "rays", "ray_kind": "diffuse", "rays_per_pixel": 4,
                "scene_params": {"triangles": 260000}}

def _capture_reason(v) -> str:
    """Why the arrays' capture exceeds twice the lists': its stage split against the lists' one raster."""
    count, scan, fill = (v("linear", f"stage:{s}") for s in ("count", "scan", "fill"))
    build = v("linked", "stage:build")
    return (f"the arrays' capture is two rasterizations, a count ({count:.3g} ms) and a fill ({fill:.3g} ms), "
            f"{count / build:.2f}× and {fill / build:.2f}× the lists' one ({build:.3g} ms), and a prefix sum between "
            f"them ({scan:.3g} ms): the two rasterizations are {(count + fill) / build:.2f}× the lists' capture, "
            f"the paper's 'twice', and the scan adds {scan / build:.2f}×")


REPRODUCTION = Reproduction(
    key="archer2019-layouts",
    paper="archer2019",
    title="CDI memory of the one-pass build (up to 25 % more); linearised arrays vs linked lists (§3.1)",
    source="§3.1",
    hardware="NVIDIA GeForce GTX 1060",
    resolution="1920x1080",
    paper_scene="Atrium and Rungholt",
    rows=(
        {"id": "cdi-one-pass", "label": "CDI of 169 × 64², one-pass build", "paper_setup": "up to 25 % more memory",
         "match": {"scene": "atrium", "method": "cdi-vpl", "effect": "vpl_range", "scene_params": {"triangles": 260000},
                   "params": {"structure.source": "one_pass", "cdi": "static"}},
         "counter:cdi_bytes": None},
        {"id": "cdi-brute-force", "label": "CDI of 169 × 64², one raster per direction",
         "paper_setup": "the baseline",
         "match": {"scene": "atrium", "method": "cdi-vpl", "effect": "vpl_range", "scene_params": {"triangles": 260000},
                   "params": {"structure.source": "raster", "structure.instanced": False, "cdi": "static"}},
         "counter:cdi_bytes": None},
        {"id": "linked", "label": "169 maps of 64², linked lists (ldm)", "paper_setup": "linked lists",
         "match": {**_LAYOUT_RAYS, "params": {"directions": 169, "resolution": 64, "structure.layout": "linked"}},
         "stage:build": None, "stage:trace": None},
        {"id": "linear", "label": "169 maps of 64², linearised arrays (ldm)", "paper_setup": "linearised arrays",
         "match": {**_LAYOUT_RAYS, "params": {"directions": 169, "resolution": 64, "structure.layout": "linear"}},
         "stage:count+scan+fill+sort": None, "stage:count+scan+fill": None, "stage:trace": None},
    ),
    claims=(
        Claim("The one-pass build stores more fragments than one raster per direction, up to 25 % more",
              "cdi-one-pass", "cdi-brute-force", ("counter:cdi_bytes",), "ratio", ratio=(1.0, 1.25),
              where="§3.1 'increasing overall CDI memory usage by up to 25%'", published="up to 1.25×",
              why="'increasing' puts the one-pass memory above the per-direction raster's (ratio > 1) and 'up to "
                  "25 %' caps it at 1.25×: the window is the paper's own words, [1, 1.25]",
              reason="the one-pass build samples a triangle on its dominant axis's raster; a direction nearly "
                     "edge-on to a wall packs those samples into few texels, where the direction's own raster "
                     "keeps one. For spread directions the expected factor is 1 / mean |n·v| ≈ 2 for axis-aligned "
                     "walls: measured 1.89× (Cornell-like, 48 × 32²) and 2.04× (atrium 4k, 169 × 32²) the "
                     "fragments on llvmpipe (docs/reference/methods/cdi_vpl.md). The paper does not say against "
                     "what its 25 % is measured"),
        Claim("Linearised arrays are slower to build than linked lists", "linear", "linked",
              ("stage:count+scan+fill+sort",), "greater", b_quantity="stage:build",
              where="§3.1 'Linearised arrays are slower to build than linked lists but faster to raycast'"),
        Claim("…but faster to raycast", "linear", "linked", ("stage:trace",), "less", where="§3.1"),
        Claim("Capture into arrays takes up to twice as long as into linked lists (1–2×)", "linear", "linked",
              ("stage:count+scan+fill",), "ratio", ratio=(1.0, 2.0), b_quantity="stage:build",
              where="§3.1 'geometry must be rasterized twice as opposed to linked lists where it is rasterized once. "
                    "For complex scenes where rasterization is a bottleneck, this can cause capture time for "
                    "arrays to be up to twice as long as for linked lists'",
              published="up to 2× (two rasterizations against one)",
              why="the words' own bounds: 'slower to build' puts the arrays' capture above the lists' (1×) and "
                  "'up to twice as long', two rasterizations against one, caps it at 2×; the capture is the "
                  "arrays' count + scan + fill (no sort) against the lists' build",
              reason=_capture_reason),
    ),
    scales={"paper": {},
            "ci": {"size": "32x32", "warmup": 0, "frames": 3,
                   "params": {"cdi-vpl": {"resolution": 16, "directions": 16}, "ldm": {"directions": {169: 16},
                                                                                       "resolution": {64: 16}}},
                   "scene_params": {"atrium": {"triangles": 4000}}}},
    notes=(
        "Memory: the CDI's own bytes (counter cdi_bytes: offsets and depths) of a CDI built once in setup, one "
        "pass against the per-direction raster (the paper's brute force); vpl_range on a 16² RSM. The paper "
        "does not say against what the 25 % is measured; the per-direction raster is exact at texel centres.",
        "The CDI here is always linearised arrays; the layout claim is tested on the same layered-structure "
        "component in the ldm adapter (169 maps of 64², structure.layout linked or linear, the same 4 diffuse "
        "rays per pixel of a 256² view): 'build' of the linked lists against count + scan + fill + sort of the "
        "arrays, and the 'trace' stage of each. ldm's lists are built sorted (lock-free sorted insert), the "
        "paper's linked lists are not (it does not say): our lists pay for sorting in their build, which "
        "lowers the arrays' capture over the lists' build (count + scan + fill, no sort: the 'up to twice' claim) "
        "against the paper's unsorted lists.",
        "On a CPU (llvmpipe) the two time claims are 'not measurable here' (whatever the difference: one run cannot measure the spread between runs, docs/reference/reports.md, 'Timing verdicts'); "
        "the memory claim gets a verdict anywhere.",
    ),
)
