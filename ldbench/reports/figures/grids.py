"""Image grids (:func:`make_grid`): one per scene content, effect with its parameters and image size: the
reference, each method's image and its absolute-error map on one scale per grid, a colour bar, a matplotlib
version of the whole grid, and the viewer's maps (:mod:`ldbench.reports.figures.viewer_values`)."""
from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldbench.core import metrics
from ldbench.core.effects import registry
from ldbench.core.exr import read_answer_channels
from ldbench.core.imageio import read_png, write_png
from ldbench.core.unbiased import REJECT_COLOURS
from ldbench.harness.naming import slug
from ldbench.reports.labels import as_number, differing_keys, label_parts

from .plotting import colorbar, colour_legend, pyplot, short_hash
from .table import ok_rows
from .viewer_values import viewer_maps

@dataclass
class GridCell:
    """One method's column of a grid: its image, error maps, caption lines and the viewer's files."""

    label: str
    image: str | None  # relative path of the method's preview PNG
    error: str | None  # relative path of the re-coloured error PNG (grid scale)
    caption: list = field(default_factory=list)
    exr: str | None = None  # the method's linear EXR
    signed: str | None = None  # signed-error PNG (diverging, symmetric grid scale)
    flip: str | None = None  # FLIP map PNG (magma, 0 … 1); image effects only
    values: str | None = None  # float values of the image for the viewer (imageio.save_values_js)
    flip_values: str | None = None  # float values of the FLIP map
    unbiased: str | None = None  # score --test unbiased: the rejection map PNG (ldbench/harness/unbiased_score.py)


@dataclass
class Grid:
    """One image grid: the reference, a :class:`GridCell` per method, the shared error scale and colour bars."""

    title: str
    anchor: str
    reference: str | None
    reference_caption: str
    cells: list
    colorbar: str | None
    vmax: float
    error_label: str
    png: str | None = None
    pdf: str | None = None
    problems: list = field(default_factory=list)
    reference_exr: str | None = None
    reference_values: str | None = None
    width: int = 0
    height: int = 0
    signed_vmax: float = 0.0  # the signed-error maps span -signed_vmax … +signed_vmax
    signed_colorbar: str | None = None
    flip_colorbar: str | None = None
    unbiased_legend: str | None = None  # the rejection maps' legend (when a row has one)
    maps_json: str | None = None  # ranges, colour maps and definitions of the maps (grids/<tag>/maps.json)


def grid_groups(df) -> dict:
    """(scene, scene_hash, effect text, size) → ok rows that have images."""
    groups: dict = {}
    for _, r in ok_rows(df).iterrows():
        if not r["images"]:
            continue
        key = (str(r["scene"]), str(r["scene_hash"]), r["effect_text"], r["size"], r["effect_slug"])
        groups.setdefault(key, []).append(r)
    return groups


def _cell_label(r, diff):
    lab, *extra = label_parts(r, diff)
    return lab + (f" ({', '.join(extra)})" if extra else "")


def make_grid(run_dir: Path, key, rows, *, matplotlib_grid: bool = True, values_budget: dict | None = None) -> Grid:
    """Write the grid's assets (error PNGs on one scale, colour bar, matplotlib grid) and describe it.
    ``values_budget`` (``{"bytes": n}``, shared by the grids of one report) caps the viewer's value files."""
    scene, shash, eff, size, eslug = key
    tag = f"{slug(scene, 30)}-{slug(eslug, 40)}-{size}-{short_hash(key)}"
    gdir = run_dir / "figures" / "grids" / tag
    gdir.mkdir(parents=True, exist_ok=True)
    problems = []
    diff = [k for k in differing_keys(rows) if k not in ("scene", "effect", "size")]
    errs, vmaxes = [], []
    for r in rows:
        rel = r["images"].get("error_exr")
        e = None
        if rel and (run_dir / rel).is_file():
            try:
                e = read_answer_channels(run_dir / rel)[..., 0]
            except Exception as ex:  # noqa: BLE001 - a broken file is reported, not fatal
                problems.append(f"cannot read {rel}: {ex}")
        elif rel:
            problems.append(f"missing {rel}")
        errs.append(e)
        vm = as_number(r["images"].get("error_vmax"))
        if vm is None and e is not None and e.size:
            vm = float(np.percentile(e[e > 0], 99)) if (e > 0).any() else 0.0
        if vm is not None:
            vmaxes.append(vm)
    vmax = max(vmaxes) if vmaxes else 0.0
    vmax = vmax if vmax > 0 else 1e-6
    cells = []
    spec = registry().get(str(rows[0]["effect"]))  # None: an effect not installed here
    for i, (r, e) in enumerate(zip(rows, errs)):
        epath = None
        if e is not None:
            epath_abs = gdir / f"{i:02d}-{slug(r['method'], 30)}-error.png"
            write_png(epath_abs, metrics.colorize(e, vmax=vmax))
            epath = epath_abs.relative_to(run_dir).as_posix()
        img = r["images"].get("image")
        if img and not (run_dir / img).is_file():
            problems.append(f"missing {img}")
            img = None
        cap = [*(spec.caption(r, _f) if spec is not None else []),
               f"{_f(r['total_ms'], 2)} ms · {_f(r['memory_mb'], 1)} MB"]
        cells.append(GridCell(_cell_label(r, diff), img, epath, cap))
        ub = r["images"].get("unbiased_reject")
        if ub and (run_dir / ub).is_file():
            cells[-1].unbiased = ub
            verdict = r.get("unbiased_verdict")
            if isinstance(verdict, str):
                cap.append(f"unbiased: {verdict} (p {_f(r.get('unbiased_p'), 3)})")
    ref = rows[0]["images"].get("reference")
    if ref and not (run_dir / ref).is_file():
        problems.append(f"missing {ref}")
        ref = None
    err_label = spec.error_label() if spec is not None else "error"
    cbar = gdir / "colorbar.png"
    colorbar(cbar, "magma", 0.0, vmax, err_label)
    ref_cap = (f"reference ({rows[0].get('ref_spp')} spp, {rows[0].get('ref_variant')})"
               if spec is None or spec.output == "image" else f"oracle ({rows[0].get('ref_variant')}): {spec.units}")
    g = Grid(title=f"{scene} — {eff} — {size.replace('x', '×')}", anchor=f"grid-{tag}", reference=ref,
             reference_caption=ref_cap, cells=cells, colorbar=cbar.relative_to(run_dir).as_posix(),
             vmax=vmax, error_label=err_label, problems=problems)
    if any(c.unbiased for c in cells):
        _unbiased_legend(gdir / "legend-unbiased.png")
        g.unbiased_legend = (gdir / "legend-unbiased.png").relative_to(run_dir).as_posix()
    try:
        viewer_maps(run_dir, g, rows, gdir, values_budget)
    except Exception as ex:  # noqa: BLE001 - the viewer's extras must not lose the grid
        problems.append(f"viewer maps: {type(ex).__name__}: {ex}")
    if matplotlib_grid:
        g.png, g.pdf = _matplotlib_grid(run_dir, g, rows, errs, tag)
    return g


def _unbiased_legend(path: Path) -> None:
    """The legend of the rejection maps of ``score --test unbiased`` (ldbench.core.unbiased.REJECT_COLOURS)."""
    names = ["not tested", "accepted", "p < α", "rejected (corrected)", "NaN / missing"]
    colour_legend(path, [np.asarray(c) / 255.0 for c in REJECT_COLOURS], names)


def _f(v, nd):
    v = as_number(v)
    if v is None:
        return "–"
    if math.isinf(v):
        return "∞"
    return f"{v:.{nd}f}"


def _matplotlib_grid(run_dir: Path, g: Grid, rows, errs, tag):
    """The whole grid as one figure: reference + methods (top row), error maps (bottom row)."""
    plt = pyplot()
    n = len(rows) + 1
    fig, axes = plt.subplots(2, n, figsize=(2.7 * n, 6.0), squeeze=False)
    for a in axes.flat:
        a.set_xticks([]), a.set_yticks([])
    if g.reference:
        axes[0, 0].imshow(read_png(run_dir / g.reference), interpolation="nearest")
    axes[0, 0].set_title(g.reference_caption, fontsize=7)
    axes[1, 0].axis("off")
    im = None
    for i, (c, e) in enumerate(zip(g.cells, errs), start=1):
        if c.image:
            axes[0, i].imshow(read_png(run_dir / c.image), interpolation="nearest")
        axes[0, i].set_title(c.label[:48], fontsize=7)
        if e is not None:
            im = axes[1, i].imshow(e, cmap="magma", vmin=0, vmax=g.vmax, interpolation="nearest")
        axes[1, i].set_title("\n".join(c.caption), fontsize=6.5)
    if im is not None:
        cb = fig.colorbar(im, ax=list(axes[1, 1:]), fraction=0.046, pad=0.02)
        cb.set_label(textwrap.fill(g.error_label, 36), fontsize=7)
        cb.ax.tick_params(labelsize=7)
    fig.suptitle(g.title, fontsize=10)
    d = run_dir / "figures"
    # bbox "tight": with one method the colour bar's ticks and label lie right of the last axes and
    # would be cut off at the figure's edge.
    fig.savefig(d / f"grid-{tag}.png", dpi=110, bbox_inches="tight", pad_inches=0.08)
    fig.savefig(d / f"grid-{tag}.pdf", bbox_inches="tight", pad_inches=0.08)
    plt.close(fig)
    return f"figures/grid-{tag}.png", f"figures/grid-{tag}.pdf"
