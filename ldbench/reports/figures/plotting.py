"""Drawing helpers every figure shares: matplotlib set up for files (:func:`pyplot`), the device footer,
saving as PNG and PDF, colour maps, a colour bar and a colour legend as PNGs of their own.

matplotlib is imported on the first drawing, not with the module: callers of the report that draw nothing
(the terminal table of ``ldbench run``) do not pay for pyplot, and the Agg backend is chosen before pyplot
loads.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no display) with the report's font sizes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10,
                         "legend.fontsize": 8, "figure.dpi": 100, "pdf.fonttype": 42})
    return plt


def colormap(name: str):
    """matplotlib's registered colour map ``name`` (``tab10``, ``magma``, ...)."""
    import matplotlib

    return matplotlib.colormaps[name]


@dataclass
class Figure:
    """One report figure: title, caption and the relative paths of its files."""

    kind: str
    title: str
    caption: str
    png: str
    pdf: str


def short_hash(*parts) -> str:
    """Six hex digits of a hash of ``parts``: keeps file names of different figures apart."""
    return hashlib.sha1(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:6]


def device_footer(fig, df):
    """Footer naming the device(s); red warning on a software rasterizer (docs/design.md)."""
    devs = sorted({str(d) for d in df["device"] if d is not None}) or ["unknown"]
    renderers = sorted({str(d) for d in df.get("gl_renderer", []) if d is not None})
    soft = "cpu-software" in devs
    text = f"device = {', '.join(devs)}"
    if soft:
        text += ": wall-clock times on a software rasterizer, not GPU times"
    elif renderers:
        text += f" — {', '.join(renderers)}"[:90]
    fig.text(0.005, 0.005, text, fontsize=7, color="#b00000" if soft else "#555555", ha="left", va="bottom")


def save(fig, run_dir: Path, name: str) -> dict:
    """Write ``figures/<name>.png`` and ``.pdf``; return their paths relative to ``run_dir``."""
    plt = pyplot()
    d = run_dir / "figures"
    d.mkdir(parents=True, exist_ok=True)
    fig.savefig(d / f"{name}.png", dpi=110)
    fig.savefig(d / f"{name}.pdf")
    plt.close(fig)
    return {"png": f"figures/{name}.png", "pdf": f"figures/{name}.pdf"}


def palette(keys):
    """{key: colour} from tab10, in the order of ``keys``."""
    cm = colormap("tab10")
    return {k: cm(i % 10) for i, k in enumerate(keys)}


def log_x(ax):
    """Log x axis with labelled decades only (minor labels overlap on narrow panels)."""
    from matplotlib.ticker import NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())


def colorbar(path: Path, cmap: str, lo: float, hi: float, label: str) -> None:
    """A horizontal colour bar PNG from ``lo`` to ``hi`` with five ticks and a label."""
    import matplotlib as mpl

    plt = pyplot()  # before matplotlib.colorbar: Agg chosen first
    fig = plt.figure(figsize=(4.2, 0.85))
    cax = fig.add_axes([0.05, 0.55, 0.9, 0.3])
    cb = mpl.colorbar.ColorbarBase(cax, cmap=mpl.colormaps[cmap], norm=mpl.colors.Normalize(lo, hi),
                                   orientation="horizontal")
    cb.set_label(label, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    ticks = np.linspace(lo, hi, 5)
    cb.set_ticks(list(ticks))
    cb.ax.set_xticklabels(["0" if abs(t) < 1e-12 * max(abs(lo), abs(hi), 1e-30) else f"{t:.2g}" for t in ticks])
    fig.savefig(path, dpi=110)
    plt.close(fig)


def colour_legend(path: Path, colours, names, *, width: float = 5.6) -> None:
    """A one-row legend PNG: a patch of each colour (RGB 0 … 1) with its name."""
    from matplotlib.patches import Patch

    plt = pyplot()
    fig = plt.figure(figsize=(width, 0.45))
    fig.legend(handles=[Patch(color=c, label=n) for c, n in zip(colours, names)],
               loc="center", ncol=len(names), fontsize=7, frameon=False, handlelength=1.2, columnspacing=1.0)
    fig.savefig(path, dpi=110)
    plt.close(fig)
