"""Ray queries' accuracy against speed (:func:`figure_rays`): hit agreement and the p95 distance error
against rays per second, the exact oracle as a star."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ldbench.harness.naming import slug
from ldbench.reports.labels import differing_keys

from .colours import method_colours
from .plotting import Figure, device_footer, pyplot, save, short_hash
from .table import config_label

def figure_rays(df, run_dir: Path, key, rows) -> Figure | None:
    """Ray queries: hit agreement and p95 distance error against rays/s, every method configuration and
    the exact oracle (agreement 1, error 0, at its own measured speed on the same batch)."""
    plt = pyplot()
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
