"""Time or memory against one swept parameter (:func:`figure_vs_param`): one line per scene, method, effect
and fixed parameters; ``d_max = inf`` drawn at the right end of the axis and labelled ∞."""
from __future__ import annotations

import json
import math
from pathlib import Path

from ldbench.harness.naming import slug
from ldbench.reports.labels import as_number, fmt_value

from .colours import method_colours
from .plotting import Figure, device_footer, log_x, pyplot, save
from .table import ok_rows

def param_label(p: str) -> str:
    """The x-axis label of a swept parameter (with its unit where it has one)."""
    return {"d_max": "d_max (scene units, m)", "pixels": "image pixels (width × height)",
            "scene.triangles": "scene triangles"}.get(p, p)


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


def figure_vs_param(df, run_dir: Path, param: str, what: str) -> Figure | None:
    """Time (``what="time"``) or memory (``"memory"``) against one swept parameter, one line per
    (scene, method, effect, other parameters) series."""
    plt = pyplot()
    ok = ok_rows(df)
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
    # series of one method: the method's colour, each its own line style and marker
    styles: dict[str, tuple[str, str, str]] = {}
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
        log_x(ax)
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
