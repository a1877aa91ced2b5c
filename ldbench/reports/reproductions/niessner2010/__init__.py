"""niessner2010: Nießner, Schäfer, Stamminger, "Fast indirect illumination using layered depth images"
(The Visual Computer 26, 2010), Table 1, Fig. 7 and the claims of §7 and §8 as data, one folder per table
(``table1``, ``fig7``, ``rays``, ``sec7``: its :class:`~ldbench.reports.reproduce.Reproduction` and its
``suite.toml``; the engine is :mod:`ldbench.reports.reproduce`; the adapter is ``ldi``, ldbench/methods/ldi).

Their setup: DirectX 10 on a GTX 285, 512 × 512, Sibenik (we have it: the registered ``sibenik``, 76,529
triangles), 16 secondary rays per primary ray; "rays/s refer to secondary rays only ... including
shading". Ours: the ``rays`` effect with 16 rays per hit pixel from Mitsuba's exact primary hits, the same
batch for every LDI configuration of a ray kind, answered by the ``trace`` stage (hit distance only, no
shading). A grid row's frame is that trace alone (the LDIs are built once in setup), so its time is the
batch's trace time and ``rays_per_s`` = rays / time. Beside it: ``hit_agreement`` and ``dist_err_p95``
against Mitsuba's exact answers to the same rays, and ``oracle_rays_per_s``, Mitsuba's speed on them on
the same machine (Dr.Jit kernel times on CUDA; wall clock on a CPU).

The paper's case for approximate rays (§7: "for lower resolutions we are much faster" than common GPU ray
tracers) is a comparison inside one row, ours against the oracle's rays/s on the same rays (a claim between
a row's two quantities); its memory statements (§1 "always less than 100 MB", §7 "15 MB up to 60 MB") are
window claims on one row.
"""
from __future__ import annotations

#: The order of the tables in `ldbench reproduce --list` (a table folder not named here follows, by name)
TABLES = ("table1", "fig7", "rays", "sec7", "views")
