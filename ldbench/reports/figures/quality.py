"""Quality against time (:func:`figure_quality`): PSNR, SSIM and FLIP against the frame time, one panel
each, with the Pareto front (:func:`pareto_front`) marked."""
from __future__ import annotations

import math
from pathlib import Path

from ldbench.harness.naming import slug

from .colours import method_colours
from .plotting import Figure, device_footer, log_x, pyplot, save, short_hash

#: The quality panels: (column, axis label, higher is better).
QUALITY = (
    ("psnr", "PSNR (dB)", True),
    ("ssim", "SSIM", True),
    ("flip", "FLIP (mean)", False),
)


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
    plt = pyplot()
    rows = [r for r in rows if not math.isnan(r["total_ms"])]
    panels = [(c, lab, hib) for c, lab, hib in QUALITY
              if any(not math.isnan(r[c]) and math.isfinite(r[c]) for r in rows)]
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
            log_x(ax)
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
