"""What the report's viewer shows beside each method's image of a grid (:func:`viewer_maps`): signed-error
and FLIP maps with their colour bars, the images' float values for the per-pixel read-out within a disk
budget, and ``maps.json`` recording ranges, colour maps and definitions."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ldbench.core import metrics
from ldbench.core.effects import registry
from ldbench.core.effects.base import effect_units
from ldbench.core.exr import read_answer_channels
from ldbench.core.imageio import read_png, save_values_js, write_png
from ldbench.harness.naming import slug

from .plotting import colorbar

#: Disk the viewer's value files of one report may take (base64 float32: ~10 MB per 800x800 RGB image);
#: beyond it the read-out shows coordinates only.
VALUES_BUDGET_BYTES = 512 * 2**20

#: Colour maps of the viewer's maps (signed: red = method brighter than the reference).
SIGNED_CMAP, FLIP_CMAP = "RdBu_r", "magma"


def viewer_maps(run_dir: Path, g, rows, gdir: Path, budget: dict | None = None) -> None:
    """The maps the report's viewer shows beside each method's image, written into the grid folder, and their
    paths recorded in the grid ``g`` (a :class:`~ldbench.reports.figures.grids.Grid` of ``rows``):

    * signed error ``mean over channels of (test − reference)`` (linear), coloured with ``RdBu_r`` on a
      symmetric range ± the largest of the methods' 99th percentiles of ``|signed|`` over its non-zero
      pixels (one range per grid);
    * the FLIP map (image effects only) with the settings of :data:`ldbench.core.metrics.FLIP_SETTINGS`, on
      FLIP's own range 0 … 1 with ``magma``. It is evaluated over every pixel (the run does not store
      the reference's hit mask), so near silhouettes it can differ from the ``flip`` column's map;
    * the images' float32 values for the per-pixel read-out (:func:`ldbench.core.imageio.save_values_js`),
      while ``budget["bytes"]`` lasts (:data:`VALUES_BUDGET_BYTES` per report by default).

    Ranges, colour maps and definitions are recorded in ``maps.json`` beside them."""
    ref_exr = g.reference[:-4] + ".exr" if g.reference and g.reference.endswith(".png") else None
    if not ref_exr or not (run_dir / ref_exr).is_file():
        if g.reference:  # no float data: the viewer still shows the PNGs
            g.height, g.width = read_png(run_dir / g.reference).shape[:2]
        return
    ref = read_answer_channels(run_dir / ref_exr)
    g.height, g.width = ref.shape[:2]
    g.reference_exr = ref_exr
    vdir = gdir / "values"
    rel = lambda p: p.relative_to(run_dir).as_posix()  # noqa: E731
    budget = {"bytes": VALUES_BUDGET_BYTES} if budget is None else budget

    def save_values(path: Path, a) -> str | None:
        need = np.asarray(a).size * 4 * 4 // 3
        if need > budget["bytes"] or not save_values_js(path, rel(path), a):
            return None
        budget["bytes"] -= need
        return rel(path)

    g.reference_values = save_values(vdir / "reference.js", ref)
    spec = registry().get(str(rows[0]["effect"]))
    with_flip = spec is not None and spec.output == "image"
    signed: list[np.ndarray | None] = []  # per cell: the signed error, the FLIP map (None: no float data)
    flips: list[np.ndarray | None] = []
    for i, (r, c) in enumerate(zip(rows, g.cells)):
        exr = r["images"].get("exr")
        test = read_answer_channels(run_dir / exr) if exr and (run_dir / exr).is_file() else None
        if test is None or test.shape != ref.shape:
            signed.append(None)
            flips.append(None)
            continue
        c.exr = exr
        stem = f"{i:02d}-{slug(r['method'], 30)}"
        c.values = save_values(vdir / f"{stem}.js", test)
        signed.append((test.astype(np.float64) - ref).mean(axis=2))
        fmap = None
        if with_flip:
            _, fmap = metrics.flip(test, ref, hdr=False, pixels_per_degree=metrics.FLIP_SETTINGS["ppd"])
            c.flip_values = save_values(vdir / f"{stem}-flip.js", fmap)
        flips.append(fmap)
    nz = [np.abs(d[d != 0]) for d in signed if d is not None]
    sv = max((float(np.percentile(a, 99)) for a in nz if a.size), default=0.0)
    g.signed_vmax = sv if sv > 0 else 1e-6
    for i, (c, d, fmap) in enumerate(zip(g.cells, signed, flips)):
        stem = f"{i:02d}-{slug(rows[i]['method'], 30)}"
        if d is not None:
            write_png(gdir / f"{stem}-signed.png",
                      metrics.colorize((d + g.signed_vmax) / (2 * g.signed_vmax), vmax=1.0, cmap=SIGNED_CMAP))
            c.signed = rel(gdir / f"{stem}-signed.png")
        if fmap is not None:
            write_png(gdir / f"{stem}-flip.png", metrics.colorize(fmap, vmax=1.0, cmap=FLIP_CMAP))
            c.flip = rel(gdir / f"{stem}-flip.png")
    units = effect_units(rows[0]["effect"])
    colorbar(gdir / "colorbar-signed.png", SIGNED_CMAP, -g.signed_vmax, g.signed_vmax,
              f"test − reference ({units}, mean over channels)")
    g.signed_colorbar = rel(gdir / "colorbar-signed.png")
    if any(f is not None for f in flips):
        colorbar(gdir / "colorbar-flip.png", FLIP_CMAP, 0.0, 1.0, "FLIP error (LDR, 0 … 1)")
        g.flip_colorbar = rel(gdir / "colorbar-flip.png")
    maps = {
        "abs": {"range": [0.0, g.vmax], "cmap": "magma", "definition": g.error_label,
                "scale_rule": "largest of the methods' 99th percentiles over valid pixels"},
        "signed": {"range": [-g.signed_vmax, g.signed_vmax], "cmap": SIGNED_CMAP,
                   "definition": "mean over channels of (test - reference), linear",
                   "scale_rule": "largest of the methods' 99th percentiles of |signed| over non-zero pixels"},
        "flip": {"range": [0.0, 1.0], "cmap": FLIP_CMAP, "settings": dict(metrics.FLIP_SETTINGS),
                 "definition": "FLIP per pixel over every pixel (no hit mask)"} if g.flip_colorbar else None,
        "png_encoding": "a map value v is shown with colour cmap((v - lo) / (hi - lo)), clipped",
        "values": "values/*.js: float32 little-endian, row-major, channels last, base64 "
                  "(ldbenchValues(key, width, height, channels, data))",
        "cells": [{"label": c.label, "image": c.image, "exr": c.exr, "signed": c.signed, "flip": c.flip}
                  for c in g.cells],
    }
    (gdir / "maps.json").write_text(json.dumps(maps, indent=1), encoding="utf-8")
    g.maps_json = rel(gdir / "maps.json")
