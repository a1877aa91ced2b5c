"""The stage-time breakdown of one scene (:func:`figure_stages`): stacked bars of the median stage times, one
bar per configuration."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ldbench.harness.naming import slug
from ldbench.reports.labels import as_number, differing_keys

from .plotting import Figure, device_footer, palette, pyplot, save, short_hash
from .table import config_label, ok_rows, sortable

def figure_stages(df, run_dir: Path, scene: str, max_bars: int = 30) -> list[Figure]:
    """Stacked bars of the median stage times (``stage_ms``), one bar per configuration of one scene."""
    plt = pyplot()
    ok = ok_rows(df)
    rows = [r for _, r in ok[ok["scene"] == scene].iterrows() if r["stage_ms"]]
    if not rows:
        return []
    rows.sort(key=lambda r: (r["effect"], str(r["falloff"]), sortable(r["d_max"]), r["method"], r["pixels"],
                             tuple((k, sortable(v)) for k, v in sorted(r["params"].items()))))
    stages: list[str] = []
    for r in rows:
        stages += [s for s in r["stage_ms"] if s not in stages]
    pal = palette(stages)
    figs = []
    chunks = [rows[i:i + max_bars] for i in range(0, len(rows), max_bars)]
    for ci, chunk in enumerate(chunks):
        diff = differing_keys(chunk)
        names = [config_label(r, diff) for r in chunk]
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
        ax.set_xticklabels(names, rotation=30 if len(chunk) > 3 else 0, ha="right" if len(chunk) > 3 else "center",
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
