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
  (:func:`_viewer_maps`).
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldbench.harness.naming import slug
from . import labels
from .labels import as_number, fmt_value
from ldbench.harness.records import effect_d_max, effect_param

MB = float(2**20)

RAY_COLUMNS = ("hit_agreement", "false_hit_rate", "false_miss_rate", "dist_err_p50", "dist_err_p95",
               "dist_err_p99", "self_hit_rate", "coverage", "rays", "rays_per_s", "oracle_rays_per_s")

QUALITY = (  # column, axis label, higher is better
    ("psnr", "PSNR (dB)", True),
    ("ssim", "SSIM", True),
    ("flip", "FLIP (mean)", False),
)


# --------------------------------------------------------------------------------------------------
# small helpers


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10,
                         "legend.fontsize": 8, "figure.dpi": 100, "pdf.fonttype": 42})
    return plt


def short_hash(*parts) -> str:
    return hashlib.sha1(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:6]


def as_dict(v) -> dict:
    if isinstance(v, dict):
        return v
    if isinstance(v, str) and v.strip():
        try:
            d = json.loads(v)
            return d if isinstance(d, dict) else {}
        except ValueError:
            return {}
    return {}


def effect_text(r) -> str:
    """``ao (quadratic, d_max = 10.3)``, ``rays (diffuse, rays_per_pixel = 4)``: the effect's own text
    (:func:`ldbench.reports.labels.effect_text`)."""
    return labels.effect_text(r["effect"], r["effect_params"])


def effect_slug(r) -> str:
    """Short file-name form of the effect: ``ao-quadratic-d10.32``, ``ao-step-dinf``, ``direct``,
    ``rays-diffuse-4`` (the effect's own label when the effect is registered)."""
    if r["effect"] == "ao":
        d = r["d_max"]
        return f"ao-{r['effect_params'].get('falloff', 'step')}-d{'inf' if d is not None and math.isinf(d) else fmt_value(d)}"
    try:
        from ldbench.core.effects import effect_from_key

        return effect_from_key({**r["effect_params"], "effect": r["effect"]}).label()
    except Exception:  # noqa: BLE001 - an unknown effect in an old table: its name
        return str(r["effect"])


def prepare(df):
    """A copy of a results table with parsed helper columns used by the report.

    Adds ``params``/``effect_params``/``scene_params``/``images``/``stage_ms`` as dicts, ``d_max``
    (float, inf, or None), ``falloff``, ``size`` ("WxH"), ``pixels``, ``memory_mb``, ``effect_text``
    and ``sweep`` (the dict of every sweepable parameter of the row, see the module docstring).
    """
    df = df.copy().reset_index(drop=True)
    for c in ("params", "effect_params", "scene_params", "images", "stage_ms", "counters", "memory",
              "stage_iqr", "metric_settings"):
        df[c] = [as_dict(v) for v in (df[c] if c in df else [None] * len(df))]
    for c in ("scene", "method", "effect", "status", "scene_hash", "device"):
        if c not in df:
            df[c] = None
    df["d_max"] = [effect_d_max(r) for _, r in df.iterrows()]
    df["falloff"] = [effect_param(r, "falloff") for _, r in df.iterrows()]
    w = [int(x) if as_number(x) is not None else 0 for x in df.get("width", [0] * len(df))]
    h = [int(x) if as_number(x) is not None else 0 for x in df.get("height", [0] * len(df))]
    df["size"] = [f"{a}x{b}" for a, b in zip(w, h)]
    df["pixels"] = [a * b for a, b in zip(w, h)]
    mem = df["memory_bytes"] if "memory_bytes" in df else [None] * len(df)
    df["memory_mb"] = [(as_number(m) / MB) if as_number(m) is not None else math.nan for m in mem]
    for c in ("total_ms", "total_ms_iqr", "wall_ms", "psnr", "ssim", "flip", "relmse", *RAY_COLUMNS):
        df[c] = [(as_number(v) if as_number(v) is not None else math.nan) for v in (df[c] if c in df else [None] * len(df))]
    q1, q3 = [], []
    for raw, med in zip(df["raw_ms"] if "raw_ms" in df else [None] * len(df), df["total_ms"]):
        tot = as_dict(raw).get("total") if raw is not None else None
        vals = [x for x in (as_number(t) for t in (tot or [])) if x is not None]
        if vals:
            a, b = np.percentile(vals, [25, 75])
            q1.append(float(a)), q3.append(float(b))
        else:
            q1.append(math.nan), q3.append(math.nan)
    df["total_q1"], df["total_q3"] = q1, q3
    df["effect_text"] = [effect_text(r) for _, r in df.iterrows()]
    df["effect_slug"] = [effect_slug(r) for _, r in df.iterrows()]
    sweeps = []
    for _, r in df.iterrows():
        s = {k: v for k, v in r["params"].items() if not isinstance(v, (dict, list))}
        if r["d_max"] is not None:
            s["d_max"] = r["d_max"]
        for k, v in r["scene_params"].items():
            if not isinstance(v, (dict, list)):
                s[f"scene.{k}"] = v
        s["pixels"] = r["pixels"]
        sweeps.append(s)
    df["sweep"] = sweeps
    return df


def param_label(p: str) -> str:
    return {"d_max": "d_max (scene units, m)", "pixels": "image pixels (width × height)",
            "scene.triangles": "scene triangles"}.get(p, p)


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
    plt = _plt()
    d = run_dir / "figures"
    d.mkdir(parents=True, exist_ok=True)
    fig.savefig(d / f"{name}.png", dpi=110)
    fig.savefig(d / f"{name}.pdf")
    plt.close(fig)
    return {"png": f"figures/{name}.png", "pdf": f"figures/{name}.pdf"}


@dataclass
class Figure:
    """One report figure: title, caption and the relative paths of its files."""

    kind: str
    title: str
    caption: str
    png: str
    pdf: str


def _sortable(v):
    """Sort key mixing numbers (numeric order, inf last) and text."""
    n = as_number(v) if not isinstance(v, str) else None
    return (0, n, "") if n is not None else (1, 0.0, str(v))


def _ok(df):
    return df[df["status"] == "ok"]


def _palette(keys):
    import matplotlib

    cm = matplotlib.colormaps["tab10"]
    return {k: cm(i % 10) for i, k in enumerate(keys)}


#: Each built-in method's colour in every report (tab20's entries), so that a method is the same colour
#: from one run's figures to the next; the reference oracle is black.
METHOD_COLOURS = {"ldm": 0, "ldm-ao": 0, "ldi": 2, "cdi-vpl": 4, "ll-oit": 6, "hbao": 8, "gtao": 10,
                  "wboit": 12, "mlab": 14, "depth-peeling": 16, "dual-depth-peeling": 18, "alpha-blend": 1,
                  "direct-raster": 3, "external": 15, "mc-ao": 5}


def method_colours(methods) -> dict:
    """{method: colour}: the fixed colour of a built-in method (:data:`METHOD_COLOURS`), and for any other
    (a plugin, an external renderer) one of tab20's colours picked by a hash of its name, so it too keeps its
    colour across reports; ``oracle (Mitsuba)`` is black."""
    import zlib

    import matplotlib

    cm = matplotlib.colormaps["tab20"]
    out = {}
    for m in methods:
        if m == "oracle (Mitsuba)":
            out[m] = (0.0, 0.0, 0.0, 1.0)
        else:
            i = METHOD_COLOURS.get(m)
            out[m] = cm(i if i is not None else zlib.crc32(str(m).encode()) % 20)
    return out


def _series_label(r, keys) -> str:
    parts = [str(r["method"])]
    for k in keys:
        if k == "scene":
            parts.append(str(r["scene"]))
        elif k == "effect":
            parts.append(str(r["effect_text"]))
        elif k in r["sweep"]:  # a swept quantity the row has (scene and image parameters, method parameters)
            parts.append(f"{k}={fmt_value(r['sweep'].get(k))}")
    return ", ".join(parts)


def _log_x(ax):
    """Log x axis with labelled decades only (minor labels overlap on narrow panels)."""
    from matplotlib.ticker import NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())


def _x_positions(values):
    """Numeric x positions; inf goes to the right of the largest finite value. Returns (xs, inf_x, log)."""
    fin = [v for v in values if v is not None and math.isfinite(v)]
    pos = [v for v in fin if v > 0]
    log = bool(pos) and len(pos) == len(fin) and max(pos) / min(pos) >= 20
    inf_x = None
    if any(v is not None and math.isinf(v) for v in values):
        if not fin:
            inf_x = 1.0
        else:
            inf_x = max(fin) * 2.0 if log else max(fin) + max((max(fin) - min(fin)) * 0.25, abs(max(fin)) * 0.25, 1.0)
    xs = [inf_x if (v is not None and math.isinf(v)) else v for v in values]
    return xs, inf_x, log


# --------------------------------------------------------------------------------------------------
# swept parameters


def swept_parameters(df) -> list[str]:
    """Parameters that take more than one value within some (scene, method, effect) group."""
    out: list[str] = []
    ok = _ok(df)
    for _, g in ok.groupby(["scene", "method", "effect"], sort=False, dropna=False):
        keys = []
        for s in g["sweep"]:
            keys += [k for k in s if k not in keys]
        for k in keys:
            vals = {json.dumps(s.get(k), default=str) for s in g["sweep"]}
            if len(vals) > 1 and k not in out and all(as_number(s.get(k)) is not None or s.get(k) is None
                                                     for s in g["sweep"]):
                out.append(k)
    return out


def figure_vs_param(df, run_dir: Path, param: str, what: str) -> Figure | None:
    """Time (``what="time"``) or memory (``"memory"``) against one swept parameter, one line per
    (scene, method, effect, other parameters) series."""
    plt = _plt()
    ok = _ok(df)
    ycol = "total_ms" if what == "time" else "memory_mb"
    rows = [r for _, r in ok.iterrows() if as_number(r["sweep"].get(param)) is not None and not math.isnan(r[ycol])]
    if what == "memory":
        rows = [r for r in rows if r[ycol] > 0]
    if not rows:
        return None
    # series: everything but the parameter fixed
    def skey(r):
        others = {k: v for k, v in r["sweep"].items() if k != param}
        eff = (r["effect"], r["falloff"]) if param == "d_max" else (r["effect"], r["falloff"], r["d_max"])
        return json.dumps([r["scene"], r["method"], eff, others], sort_keys=True, default=str)

    series: dict = {}
    for r in rows:
        series.setdefault(skey(r), []).append(r)
    series = {k: v for k, v in series.items() if len({as_number(r["sweep"][param]) for r in v}) > 1}
    if not series:
        return None
    # which attributes differ between series (to keep labels short)
    first = [v[0] for v in series.values()]
    diff = []
    if len({r["scene"] for r in first}) > 1:
        diff.append("scene")
    if param != "d_max" and len({r["effect_text"] for r in first}) > 1:
        diff.append("effect")
    elif param == "d_max" and len({(r["effect"], r["falloff"]) for r in first}) > 1:
        diff.append("falloff")
    allk = sorted({k for r in first for k in r["sweep"] if k != param})
    for k in allk:
        if k.startswith("scene.") and "scene" in diff:
            continue  # different scenes: their builder parameters are not comparable
        if k == "pixels" and "scene" in diff and len({r["size"] for r in first}) == len({r["scene"] for r in first}):
            continue
        if any(k not in r["sweep"] for r in first):
            continue  # a parameter of only some methods
        if len({json.dumps(r["sweep"].get(k), default=str) for r in first}) > 1:
            diff.append(k)
    allx = [as_number(r["sweep"][param]) for v in series.values() for r in v]
    xs_all, inf_x, log = _x_positions(allx)
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    pal = method_colours(dict.fromkeys(rs[0]["method"] for rs in series.values()))
    styles = {}  # series of one method: the method's colour, each its own line style and marker
    for k, rs in series.items():
        n = sum(1 for v in styles.values() if v[0] == rs[0]["method"])
        styles[k] = (rs[0]["method"], ("-", "--", ":", "-.")[n % 4], "os^Dv"[n % 5])
    for k, rs in series.items():
        rs = sorted(rs, key=lambda r: as_number(r["sweep"][param]))
        x = [inf_x if math.isinf(as_number(r["sweep"][param])) else as_number(r["sweep"][param]) for r in rs]
        y = [r[ycol] for r in rs]
        lab = _series_label(rs[0], [d for d in diff if d != "falloff"])
        if "falloff" in diff:
            lab += f", {rs[0]['falloff']}"
        if what == "time":
            lo = [max(r[ycol] - r["total_q1"], 0.0) if not math.isnan(r["total_q1"]) else
                  (r["total_ms_iqr"] / 2 if not math.isnan(r["total_ms_iqr"]) else 0.0) for r in rs]
            hi = [max(r["total_q3"] - r[ycol], 0.0) if not math.isnan(r["total_q3"]) else
                  (r["total_ms_iqr"] / 2 if not math.isnan(r["total_ms_iqr"]) else 0.0) for r in rs]
            ax.errorbar(x, y, yerr=[lo, hi], marker=styles[k][2], ls=styles[k][1], capsize=3,
                        color=pal[styles[k][0]], label=lab)
        else:
            ax.plot(x, y, marker=styles[k][2], ls=styles[k][1], color=pal[styles[k][0]], label=lab)
    if log:
        _log_x(ax)
    ticks = sorted({v for v in xs_all if v is not None and v != inf_x})
    if len(ticks) <= 12:  # label the measured values themselves (∞ for d_max = inf)
        ax.set_xticks(ticks + ([inf_x] if inf_x is not None else []))
        ax.set_xticklabels([fmt_value(float(t)) for t in ticks] + (["∞"] if inf_x is not None else []))
        ax.minorticks_off()
    ax.set_xlabel(param_label(param))
    ax.set_ylabel("time per frame (ms): median, quartiles" if what == "time" else "memory (MB = 2^20 bytes)")
    ax.grid(True, alpha=0.3)
    title = f"{'Time' if what == 'time' else 'Memory'} vs {param}"
    ax.set_title(title)
    ax.legend(loc="best")
    device_footer(fig, df)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    files = save(fig, run_dir, f"{what}-vs-{slug(param)}")
    cap = (f"{'Median frame time (error bars: first to third quartile)' if what == 'time' else 'GPU memory'} "
           f"against {param}; one line per scene, method, effect and fixed parameters.")
    return Figure(f"{what}-vs-param", title, cap, **files)


# --------------------------------------------------------------------------------------------------
# stage breakdown


def config_label(r, differing: list[str]) -> str:
    """The method on one line, what sets the row apart (:func:`ldbench.reports.labels.label_parts`) below."""
    parts = labels.label_parts(r, differing)
    return "\n".join([parts[0], ", ".join(parts[1:])]) if len(parts) > 1 else parts[0]


differing_keys = labels.differing_keys


def figure_stages(df, run_dir: Path, scene: str, max_bars: int = 30) -> list[Figure]:
    """Stacked bars of the median stage times (``stage_ms``), one bar per configuration of one scene."""
    plt = _plt()
    ok = _ok(df)
    rows = [r for _, r in ok[ok["scene"] == scene].iterrows() if r["stage_ms"]]
    if not rows:
        return []
    rows.sort(key=lambda r: (r["effect"], str(r["falloff"]), _sortable(r["d_max"]), r["method"], r["pixels"],
                             tuple((k, _sortable(v)) for k, v in sorted(r["params"].items()))))
    stages: list[str] = []
    for r in rows:
        stages += [s for s in r["stage_ms"] if s not in stages]
    pal = _palette(stages)
    figs = []
    chunks = [rows[i:i + max_bars] for i in range(0, len(rows), max_bars)]
    for ci, chunk in enumerate(chunks):
        diff = differing_keys(chunk)
        labels = [config_label(r, diff) for r in chunk]
        fig, ax = plt.subplots(figsize=(max(7.5, 1.0 * len(chunk) + 3.5), 5.2))
        x = np.arange(len(chunk))
        bottom = np.zeros(len(chunk))
        for s in stages:
            v = np.array([as_number(r["stage_ms"].get(s)) or 0.0 for r in chunk])
            if not v.any():
                continue
            ax.bar(x, v, bottom=bottom, color=pal[s], label=s, width=0.7)
            bottom += v
        # Headroom above the tallest bar: zero-height segments on top of a stack make matplotlib's
        # autoscale stop exactly at the bar's top (their sticky edge), so set the limit explicitly.
        ax.set_ylim(0.0, (float(bottom.max()) or 1.0) * 1.08)
        ax.set_xticks(x)
        ax.set_xticklabels(labels, rotation=30 if len(chunk) > 3 else 0, ha="right" if len(chunk) > 3 else "center",
                           fontsize=8)
        ax.set_ylabel("median stage time (ms)")
        ax.set_title(f"Stage-time breakdown — {scene}" + (f" ({ci + 1}/{len(chunks)})" if len(chunks) > 1 else ""))
        ax.legend(title="stage", loc="upper left", bbox_to_anchor=(1.0, 1.0))
        ax.grid(True, axis="y", alpha=0.3)
        device_footer(fig, df)
        fig.tight_layout(rect=(0, 0.03, 1, 1))
        name = f"stages-{slug(scene, 40)}-{short_hash(scene)}" + (f"-{ci + 1}" if len(chunks) > 1 else "")
        files = save(fig, run_dir, name)
        figs.append(Figure("stages", f"Stage times — {scene}",
                           "Median time of each stage per frame, stacked (their sum is the frame total "
                           "before taking medians, so the bar height can differ slightly from total_ms).",
                           **files))
    return figs


# --------------------------------------------------------------------------------------------------
# quality vs time


def pareto_front(times, quality, higher_is_better=True) -> list[int]:
    """Indices of the Pareto-optimal points (lower time, better quality), sorted by time."""
    pts = [(t, q if higher_is_better else -q, i) for i, (t, q) in enumerate(zip(times, quality))
           if t is not None and q is not None and math.isfinite(t) and math.isfinite(q)]
    pts.sort(key=lambda p: (p[0], -p[1]))
    front, best = [], -math.inf
    for t, q, i in pts:
        if q > best:
            front.append(i)
            best = q
    return front


def figure_quality(df, run_dir: Path, key, rows) -> Figure | None:
    """PSNR / SSIM / FLIP against time, one panel each, Pareto front marked."""
    plt = _plt()
    rows = [r for r in rows if not math.isnan(r["total_ms"])]
    panels = [(c, lab, hib) for c, lab, hib in QUALITY if any(not math.isnan(r[c]) and math.isfinite(r[c]) for r in rows)]
    if not rows or not panels:
        return None
    methods = list(dict.fromkeys(r["method"] for r in rows))
    pal = method_colours(methods)
    fig, axes = plt.subplots(1, len(panels), figsize=(4.4 * len(panels), 4.2), squeeze=False)
    times = [r["total_ms"] for r in rows]
    log = min(times) > 0 and max(times) / min(times) >= 20
    for ax, (c, lab, hib) in zip(axes[0], panels):
        q = [r[c] for r in rows]
        for m in methods:
            idx = [i for i, r in enumerate(rows) if r["method"] == m and math.isfinite(q[i])]
            ax.scatter([times[i] for i in idx], [q[i] for i in idx], color=pal[m], label=m, s=30, zorder=3)
        front = pareto_front(times, q, hib)
        if front:
            ft = [times[i] for i in front]
            fq = [q[i] for i in front]
            ax.step(ft, fq, where="post", color="k", lw=1.0, ls="--", zorder=2, label="Pareto front")
            ax.scatter(ft, fq, s=110, facecolors="none", edgecolors="k", lw=1.2, zorder=4)
        ax.set_xlabel("time per frame (ms)")
        ax.set_ylabel(lab + ("" if hib else " — lower is better"))
        if log:
            _log_x(ax)
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(loc="best")
    scene, eff, size, eslug = key
    fig.suptitle(f"Quality vs time — {scene} — {eff} — {size}")
    device_footer(fig, df)
    fig.tight_layout(rect=(0, 0.03, 1, 0.95))
    files = save(fig, run_dir, f"quality-{slug(scene, 30)}-{slug(eslug, 40)}-{size}-{short_hash(key)}")
    return Figure("quality", f"Quality vs time — {scene} — {eff} — {size}",
                  "Each point is one configuration; the dashed step line and rings mark the Pareto front "
                  "(no other configuration is both faster and better).", **files)


# --------------------------------------------------------------------------------------------------
# image grids


@dataclass
class GridCell:
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


def _read_exr(path: Path):
    from ldbench.core.exr import read_exr

    ch = read_exr(str(path))
    keys = [k for k in ("R", "G", "B") if k in ch] or [k for k in ("Y",) if k in ch] or list(ch)[:1]
    return np.stack([ch[k] for k in keys], -1).astype(np.float32)


def grid_groups(df) -> dict:
    """(scene, scene_hash, effect text, size) → ok rows that have images."""
    groups: dict = {}
    for _, r in _ok(df).iterrows():
        if not r["images"]:
            continue
        key = (str(r["scene"]), str(r["scene_hash"]), r["effect_text"], r["size"], r["effect_slug"])
        groups.setdefault(key, []).append(r)
    return groups


def _cell_label(r, diff):
    lab, *extra = labels.label_parts(r, diff)
    return lab + (f" ({', '.join(extra)})" if extra else "")


def make_grid(run_dir: Path, key, rows, *, matplotlib_grid: bool = True, values_budget: dict | None = None) -> Grid:
    """Write the grid's assets (error PNGs on one scale, colour bar, matplotlib grid) and describe it.
    ``values_budget`` (``{"bytes": n}``, shared by the grids of one report) caps the viewer's value files."""
    from ldbench.core import metrics
    from ldbench.core.imageio import write_png

    plt = _plt()
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
                e = _read_exr(run_dir / rel)[..., 0]
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
        if r["effect"] == "rays":
            cap = [f"hit agreement {_f(r['hit_agreement'], 4)} · p95 {_f(r['dist_err_p95'], 4)}",
                   f"self hits {_f(r['self_hit_rate'], 4)} · {_f(r['rays_per_s'] / 1e6, 3)} Mrays/s",
                   f"{_f(r['total_ms'], 2)} ms · {_f(r['memory_mb'], 1)} MB"]
        else:
            cap = [f"PSNR {_f(r['psnr'], 2)} dB · SSIM {_f(r['ssim'], 3)}",
                   f"FLIP {_f(r['flip'], 3)} · relMSE {_f(r['relmse'], 4)}",
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
    if rows[0]["effect"] == "rays":
        err_label = "fraction of the pixel's rays where hit / miss disagree with the oracle"
    else:
        units = "AO units" if rows[0]["effect"] == "ao" else "linear radiance"
        err_label = f"|test − reference| ({units}, mean over channels)"
    cbar = gdir / "colorbar.png"
    _colorbar(cbar, "magma", 0.0, vmax, err_label)
    ref_cap = (f"oracle ({rows[0].get('ref_variant')}): fraction of rays that hit" if rows[0]["effect"] == "rays"
               else f"reference ({rows[0].get('ref_spp')} spp, {rows[0].get('ref_variant')})")
    g = Grid(title=f"{scene} — {eff} — {size.replace('x', '×')}", anchor=f"grid-{tag}", reference=ref,
             reference_caption=ref_cap, cells=cells, colorbar=cbar.relative_to(run_dir).as_posix(),
             vmax=vmax, error_label=err_label, problems=problems)
    if any(c.unbiased for c in cells):
        _unbiased_legend(gdir / "legend-unbiased.png")
        g.unbiased_legend = (gdir / "legend-unbiased.png").relative_to(run_dir).as_posix()
    try:
        _viewer_maps(run_dir, g, rows, gdir, values_budget)
    except Exception as ex:  # noqa: BLE001 - the viewer's extras must not lose the grid
        problems.append(f"viewer maps: {type(ex).__name__}: {ex}")
    if matplotlib_grid:
        g.png, g.pdf = _matplotlib_grid(run_dir, g, rows, errs, tag)
    return g


def _colorbar(path: Path, cmap: str, lo: float, hi: float, label: str) -> None:
    """A horizontal colour bar PNG from ``lo`` to ``hi`` with five ticks and a label."""
    import matplotlib as mpl

    plt = _plt()
    fig = plt.figure(figsize=(4.2, 0.85))
    cax = fig.add_axes([0.05, 0.55, 0.9, 0.3])
    cb = mpl.colorbar.ColorbarBase(cax, cmap=mpl.colormaps[cmap], norm=mpl.colors.Normalize(lo, hi),
                                   orientation="horizontal")
    cb.set_label(label, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    ticks = np.linspace(lo, hi, 5)
    cb.set_ticks(ticks)
    cb.ax.set_xticklabels(["0" if abs(t) < 1e-12 * max(abs(lo), abs(hi), 1e-30) else f"{t:.2g}" for t in ticks])
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _unbiased_legend(path: Path) -> None:
    """The legend of the rejection maps of ``score --test unbiased`` (ldbench.core.unbiased.REJECT_COLOURS)."""
    from matplotlib.patches import Patch

    from ldbench.core.unbiased import REJECT_COLOURS

    plt = _plt()
    names = ["not tested", "accepted", "p < α", "rejected (corrected)", "NaN / missing"]
    fig = plt.figure(figsize=(5.6, 0.45))
    fig.legend(handles=[Patch(color=np.asarray(c) / 255.0, label=n) for c, n in zip(REJECT_COLOURS, names)],
               loc="center", ncol=5, fontsize=7, frameon=False, handlelength=1.2, columnspacing=1.0)
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: Disk the viewer's value files of one report may take (base64 float32: ~10 MB per 800x800 RGB image);
#: beyond it the read-out shows coordinates only.
VALUES_BUDGET_BYTES = 512 * 2**20

#: Colour maps of the viewer's maps (signed: red = method brighter than the reference).
SIGNED_CMAP, FLIP_CMAP = "RdBu_r", "magma"


def _viewer_maps(run_dir: Path, g: Grid, rows, gdir: Path, budget: dict | None = None) -> None:
    """The maps the report's viewer shows beside each method's image, written into the grid folder:

    * signed error ``mean over channels of (test − reference)`` (linear), coloured with ``RdBu_r`` on a
      symmetric range ± the largest of the methods' 99th percentiles of ``|signed|`` over its non-zero
      pixels (one range per grid);
    * the FLIP map (image effects only) with the settings of :data:`ldbench.core.metrics.FLIP_SETTINGS`, on
      FLIP's own range 0 … 1 with ``magma``. It is evaluated over every pixel (the run does not store
      the reference's hit mask), so near silhouettes it can differ from the ``flip`` column's map;
    * the images' float32 values for the per-pixel read-out (:func:`ldbench.core.imageio.save_values_js`),
      while ``budget["bytes"]`` lasts (:data:`VALUES_BUDGET_BYTES` per report by default).

    Ranges, colour maps and definitions are recorded in ``maps.json`` beside them."""
    import matplotlib.image as mpimg

    from ldbench.core import metrics
    from ldbench.core.effects import registry
    from ldbench.core.imageio import save_values_js, write_png

    ref_exr = g.reference[:-4] + ".exr" if g.reference and g.reference.endswith(".png") else None
    if not ref_exr or not (run_dir / ref_exr).is_file():
        if g.reference:  # no float data: the viewer still shows the PNGs
            g.height, g.width = mpimg.imread(str(run_dir / g.reference)).shape[:2]
        return
    ref = _read_exr(run_dir / ref_exr)
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
    signed, flips = [], []
    for i, (r, c) in enumerate(zip(rows, g.cells)):
        exr = r["images"].get("exr")
        test = _read_exr(run_dir / exr) if exr and (run_dir / exr).is_file() else None
        if test is None or test.shape != ref.shape:
            signed.append(None), flips.append(None)
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
    units = {"ao": "AO units", "rays": "fraction of rays that hit"}.get(str(rows[0]["effect"]), "linear")
    _colorbar(gdir / "colorbar-signed.png", SIGNED_CMAP, -g.signed_vmax, g.signed_vmax,
              f"test − reference ({units}, mean over channels)")
    g.signed_colorbar = rel(gdir / "colorbar-signed.png")
    if any(f is not None for f in flips):
        _colorbar(gdir / "colorbar-flip.png", FLIP_CMAP, 0.0, 1.0, "FLIP error (LDR, 0 … 1)")
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


def _f(v, nd):
    v = as_number(v)
    if v is None:
        return "–"
    if math.isinf(v):
        return "∞"
    return f"{v:.{nd}f}"


def _matplotlib_grid(run_dir: Path, g: Grid, rows, errs, tag):
    """The whole grid as one figure: reference + methods (top row), error maps (bottom row)."""
    import matplotlib.image as mpimg

    plt = _plt()
    n = len(rows) + 1
    fig, axes = plt.subplots(2, n, figsize=(2.7 * n, 6.0), squeeze=False)
    for a in axes.flat:
        a.set_xticks([]), a.set_yticks([])
    if g.reference:
        axes[0, 0].imshow(mpimg.imread(str(run_dir / g.reference)), interpolation="nearest")
    axes[0, 0].set_title(g.reference_caption, fontsize=7)
    axes[1, 0].axis("off")
    im = None
    for i, (c, e) in enumerate(zip(g.cells, errs), start=1):
        if c.image:
            axes[0, i].imshow(mpimg.imread(str(run_dir / c.image)), interpolation="nearest")
        axes[0, i].set_title(c.label[:48], fontsize=7)
        if e is not None:
            im = axes[1, i].imshow(e, cmap="magma", vmin=0, vmax=g.vmax, interpolation="nearest")
        axes[1, i].set_title("\n".join(c.caption), fontsize=6.5)
    if im is not None:
        import textwrap

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


# --------------------------------------------------------------------------------------------------
# all figures


def write_figures(run_dir: Path, df, problems: list) -> list[Figure]:
    """Every data figure of a prepared table (see :func:`prepare`); failures are appended to
    ``problems`` as text instead of stopping the report."""
    figs: list[Figure] = []

    def attempt(what, fn, *a):
        try:
            out = fn(*a)
        except Exception as e:  # noqa: BLE001 - one broken figure must not lose a finished run
            import traceback

            problems.append(f"{what}: {type(e).__name__}: {e}")
            traceback.print_exc()
            return
        if isinstance(out, list):
            figs.extend(out)
        elif out is not None:
            figs.append(out)

    ok = _ok(df)
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
    for _, r in ok[ok["effect"] == "rays"].iterrows():
        rays.setdefault((str(r["scene"]), r["effect_text"], r["size"], r["effect_slug"]), []).append(r)
    for key, rows in rays.items():
        attempt(f"ray accuracy figure {key}", figure_rays, df, run_dir, key, rows)
    return figs


def figure_rays(df, run_dir: Path, key, rows) -> Figure | None:
    """Ray queries: hit agreement and p95 distance error against rays/s, every method configuration and
    the exact oracle (agreement 1, error 0, at its own measured speed on the same batch)."""
    plt = _plt()
    rows = [r for r in rows if math.isfinite(r["rays_per_s"])]
    if not rows:
        return None
    methods = list(dict.fromkeys(r["method"] for r in rows))
    pal = method_colours(methods + ["oracle (Mitsuba)"])
    diff = [k for k in differing_keys(rows) if k not in ("scene", "effect", "size", "method")]
    panels = [("hit_agreement", "hit agreement (fraction of rays)"),
              ("dist_err_p95", "p95 |t − t_ref| / scene diagonal — lower is better")]
    fig, axes = plt.subplots(1, 2, figsize=(10.5, 4.4), squeeze=False)
    oracle = [r["oracle_rays_per_s"] for r in rows if math.isfinite(r["oracle_rays_per_s"])]
    for ax, (c, lab) in zip(axes[0], panels):
        for m in methods:
            pts = [r for r in rows if r["method"] == m and math.isfinite(r[c])]
            ax.scatter([r["rays_per_s"] for r in pts], [r[c] for r in pts], color=pal[m], label=m, s=32, zorder=3)
            for r in pts:
                if diff:
                    ax.annotate(config_label(r, diff), (r["rays_per_s"], r[c]), fontsize=6,
                                xytext=(3, 3), textcoords="offset points")
        if oracle:
            ax.scatter([float(np.median(oracle))], [1.0 if c == "hit_agreement" else 0.0], marker="*", s=160,
                       color=pal["oracle (Mitsuba)"], label="oracle (Mitsuba)", zorder=4)
        ax.set_xscale("log")
        ax.set_xlabel("rays per second (trace stage; oracle: its own time on the same batch)")
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3, which="both")
    axes[0][0].legend(loc="best", fontsize=8)
    timing = {str(r.get("oracle_timing")) for r in rows}
    scene, eff, size, eslug = key
    fig.suptitle(f"Ray queries: accuracy vs speed — {scene} — {eff} — {size}")
    device_footer(fig, df)
    fig.tight_layout(rect=(0, 0.03, 1, 0.94))
    files = save(fig, run_dir, f"rays-{slug(scene, 30)}-{slug(eslug, 40)}-{size}-{short_hash(key)}")
    return Figure("rays", f"Ray queries: accuracy vs speed — {scene} — {eff} — {size}",
                  "Each point is a method configuration on the same ray batch; the star is the exact oracle "
                  f"(oracle timing: {', '.join(sorted(timing))}; 'wall' = wall clock on the CPU).", **files)
