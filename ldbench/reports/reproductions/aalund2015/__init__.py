"""aalund2015: Aalund, Frisvad, Bærentzen, "Interactive Global Illumination Effects Using
Deterministically Directed Layered Depth Maps" (EGSR 2015): Figures 8, 9 and 10 and §3.1/§4.1 as data, one
folder per table (``fig8``, ``fig9``, ``fig8_real``, ``fig10``, ``trace``: its
:class:`~ldbench.reports.reproduce.Reproduction` and its ``suite.toml``; the engine is
:mod:`ldbench.reports.reproduce`). This package holds what the tables share: the d_max scaling and the AO
tables' ci scale.

Scene scaling: Crytek Sponza (the paper's scene; 262,267 triangles) spans about 3720.9 × 1555.9 ×
2288.2 model units (x ∈ [-1920.9, 1799.9], y ∈ [-126.4, 1429.4], z ∈ [-1182.8, 1105.4]). The paper's
"d_max = 1280m" is in these model units (the printed "m" cannot be metres: the courtyard would be
3.7 km long), i.e. 1280 / 3720.9 = 0.344 of the model's length. Our stand-in `atrium` (260,000
triangles) is 30 m long (x ∈ [-15, 15]), so d_max = 0.344 · 30 m = 10.32 m.
"""
from __future__ import annotations

SPONZA_LENGTH_UNITS = 3720.86
ATRIUM_LENGTH_M = 30.0
FIG8_D_MAX = round(1280.0 * ATRIUM_LENGTH_M / SPONZA_LENGTH_UNITS, 2)  # 10.32 m
SMALL_D_MAX = 0.25  # "as d_max → 0" (§5.1): 0.25 m ≈ 31 Sponza units

#: The ci scale of the AO tables (fig8, fig9, fig8_real): tiny, for llvmpipe
CI_AALUND = {
    "size": "32x32", "spp": 16, "warmup": 1, "frames": 3,
    "params": {"ldm-ao": {"directions": 16, "resolution": {200: 64, 50: 16}},
               "hbao": {"max_radius_px": 64.0}},
    "scene_params": {"atrium": {"triangles": 4000}, "hairball": {"triangles": 2000}},
}

#: The order of the tables in `ldbench reproduce --list` (a table folder not named here follows, by name)
TABLES = ("fig8", "fig9", "fig8_real", "fig10", "trace")
