"""Matplotlib figures and image-grid assets of a run directory (used by :mod:`ldbench.reports.report`).

Every figure is written as PNG (for the HTML page) and PDF (for papers) under ``<run>/figures/``, with
axis labels that carry units (ms, MB, dB) and a footer naming the device; on a software rasterizer
(``device = cpu-software``) the footer says in red that times are wall clock on llvmpipe.

Conventions
-----------
* **Time** is ``total_ms`` (docs/design.md, "Timing protocol"); error bars span the first to the third quartile of
  the raw per-frame totals (``raw_ms["total"]``; ± ``total_ms_iqr``/2 when raw samples are missing).
* **Memory** is ``memory_bytes`` in MB, where 1 MB = 2**20 bytes (MiB), like ``summary.md``.
* A **parameter is swept** when it takes more than one value among the rows of one
  (scene, method, effect) group. Parameters are the method's parameters (``params``), the AO distance
  ``d_max`` (from ``effect_params``; ``inf`` is drawn at the right end of the axis and labelled ∞),
  scene builder parameters (``scene.<name>``, e.g. ``scene.triangles``) and the image size
  (``pixels`` = width × height).
* **Pareto front** (quality vs time): the rows that no other row beats on both time (lower is better)
  and quality (higher PSNR / SSIM, lower FLIP); drawn as a step line through ringed points.
* **Image grids**: one per (scene content, effect with its parameters, image size): the reference,
  each method's image (the runner's PNG previews, which share the reference's exposure), and each
  method's absolute-error map |test − reference| (mean over channels, 0 on the background) coloured
  with ``magma`` on one scale per grid: 0 … the largest of the methods' 99th-percentile errors over
  valid pixels (``images.error_vmax`` written by the runner). The HTML page shows the grid from these
  PNGs plus a colour-bar image; a matplotlib version of the whole grid is written too. For the
  report's viewer each grid also gets signed-error and FLIP maps and the images' float values
  (:func:`~ldbench.reports.figures.viewer_values.viewer_maps`).

Modules: :mod:`~ldbench.reports.figures.table` (the prepared table, swept parameters, row labels),
:mod:`~ldbench.reports.figures.plotting` (matplotlib, saving, colour bars),
:mod:`~ldbench.reports.figures.colours` (each method's colour), one module per figure kind
(:mod:`~ldbench.reports.figures.stages`, :mod:`~ldbench.reports.figures.vs_param`,
:mod:`~ldbench.reports.figures.quality`, :mod:`~ldbench.reports.figures.rays`), the image grids
(:mod:`~ldbench.reports.figures.grids`) and the viewer's maps and value files
(:mod:`~ldbench.reports.figures.viewer_values`); :func:`write_figures` draws every data figure.
"""
from __future__ import annotations

import traceback
from pathlib import Path

from ldbench.core.effects import registry

from .plotting import Figure
from .quality import figure_quality
from .rays import figure_rays
from .stages import figure_stages
from .table import ok_rows, swept_parameters
from .vs_param import figure_vs_param


def write_figures(run_dir: Path, df, problems: list) -> list[Figure]:
    """Every data figure of a prepared table (see :func:`~ldbench.reports.figures.table.prepare`); failures
    are appended to ``problems`` as text instead of stopping the report."""
    figs: list[Figure] = []

    def attempt(what, fn, *a):
        try:
            out = fn(*a)
        except Exception as e:  # noqa: BLE001 - one broken figure must not lose a finished run
            problems.append(f"{what}: {type(e).__name__}: {e}")
            traceback.print_exc()
            return
        if isinstance(out, list):
            figs.extend(out)
        elif out is not None:
            figs.append(out)

    ok = ok_rows(df)
    for scene in dict.fromkeys(ok["scene"]):
        attempt(f"stage figure {scene}", figure_stages, df, run_dir, scene)
    for p in swept_parameters(df):
        attempt(f"time vs {p}", figure_vs_param, df, run_dir, p, "time")
        attempt(f"memory vs {p}", figure_vs_param, df, run_dir, p, "memory")
    groups: dict = {}
    for _, r in ok.iterrows():
        groups.setdefault((str(r["scene"]), r["effect_text"], r["size"], r["effect_slug"]), []).append(r)
    for key, rows in groups.items():
        attempt(f"quality figure {key}", figure_quality, df, run_dir, key, rows)
    rays: dict = {}
    specs = registry()
    for _, r in ok[[("rays" in specs[e].figures) if e in specs else False for e in ok["effect"]]].iterrows():
        rays.setdefault((str(r["scene"]), r["effect_text"], r["size"], r["effect_slug"]), []).append(r)
    for key, rows in rays.items():
        attempt(f"ray accuracy figure {key}", figure_rays, df, run_dir, key, rows)
    return figs
