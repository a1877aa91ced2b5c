"""History plots: ``ldbench history plot`` draws the per-machine history (:mod:`ldbench.harness.history`) as one
PNG per machine and benchmark and lists the detected change points in ``changes.md`` (the plots and the
detection are described in :mod:`ldbench.harness.history`'s docstring).
"""
from __future__ import annotations

import math
import os
from html import escape
from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write, atomic_write_text, check_output_path, check_replaceable
from ldbench.harness.history import DEFAULT_HISTORY_DIR, detect_change_points, load_history
from ldbench.harness.naming import slug
from ldbench.harness.records import summarize_samples

# Heavy: matplotlib, pandas and the compare modules (pandas, scipy) are imported by the functions that plot or
# tabulate, so importing this module stays light.


#: A benchmark's identity over time: the suite entry, not the method's parameters, so that a commit
#: changing a method's defaults shows up as a step in its series (marked "params" on the plot).
HISTORY_MATCH = ("scene", "scene_params", "method", "effect", "effect_params", "width", "height")


def _series(df):
    """One point per run for every benchmark: ``{key: (label, DataFrame of points)}``.

    Benchmarks are keyed by :data:`HISTORY_MATCH`; if a run holds several rows of one such key (a
    parameter sweep), the method parameters join the key (:data:`ldbench.harness.compare.match.DEFAULT_MATCH`).
    """
    import pandas as pd
    from ldbench.harness.compare.match import DEFAULT_MATCH, canonical, row_value, row_key, benchmark_labels

    match = HISTORY_MATCH
    pairs = [(row_value(r, "run_id"), row_key(r, match)) for _, r in df.iterrows()]
    if len(set(pairs)) < len(pairs):
        match = DEFAULT_MATCH
    keyed = {}
    for _, row in df.iterrows():
        keyed.setdefault(row_key(row, match), []).append(row)
    labels = benchmark_labels({k: rows[-1] for k, rows in keyed.items()})
    out = {}
    for k, rows in keyed.items():
        pts = []
        for row in rows:
            ok = row_value(row, "status") == "ok"
            raw = row_value(row, "raw_ms") or {}
            s = summarize_samples((raw.get("total") or raw.get("wall") or []) if isinstance(raw, dict) else [])
            med = row_value(row, "total_ms")
            med = float(med) if (ok and med is not None) else math.nan
            if s["n"]:
                q1, q3 = s["q1"], s["q3"]
            else:
                iqr = row_value(row, "total_ms_iqr")
                half = float(iqr) / 2 if iqr is not None else 0.0
                q1, q3 = med - half, med + half
            qcol = _quality_column(row)
            psnr = row_value(row, qcol)
            commit = str(row_value(row, "commit") or "")[:7] or "?"
            if row_value(row, "dirty"):
                commit += "*"
            t = str(row_value(row, "time") or "")
            pts.append({"run_id": row_value(row, "run_id"), "time": t, "commit": commit,
                        "total_ms": med, "q1": q1 if ok else math.nan, "q3": q3 if ok else math.nan,
                        "psnr": float(psnr) if (ok and psnr is not None) else math.nan,
                        "status": row_value(row, "status"), "params": canonical(row_value(row, "params"))})
        p = pd.DataFrame(pts).drop_duplicates("run_id", keep="last").reset_index(drop=True)
        p["psnr"] = p["psnr"].replace([np.inf], np.nan)  # a perfect match has no place on a dB axis
        p.attrs["quality"] = _quality_column(rows[-1])
        out[k] = (labels[k], p)
    return out


def _quality_column(row) -> str:
    """The quality series of a benchmark: PSNR for image effects, else the first metric its effect
    gates (``rays``: hit agreement). Stored under the key "psnr" of the series."""
    from ldbench.harness.compare.gate import gated_metrics

    gate = gated_metrics(row)
    return gate[0][0] if gate else "psnr"


def plot_history(history_dir=DEFAULT_HISTORY_DIR, out_dir=None, *, machine: str | None = None,
                 alpha: float = 0.01, min_effect: float = 0.10, min_db: float = 0.5,
                 min_size: int = 3, html: bool = True) -> dict:
    """Draw one PNG per machine and benchmark, write ``changes.md`` and (``html``) ``index.html``.

    Returns ``{"pngs": [Path], "changes": Path, "change_points": [dict], "html": Path | None}``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not 0 < alpha < 1:
        raise LdbenchError(f"--alpha must be in (0, 1), got {alpha}")
    if min_size < 1:
        raise LdbenchError(f"--min-size must be >= 1, got {min_size}")
    for name, v in (("min-effect", min_effect), ("min-db", min_db)):
        if not (math.isfinite(v) and v >= 0):
            raise LdbenchError(f"--{name} must be a finite number >= 0, got {v}")

    out = Path(out_dir) if out_dir else Path(history_dir) / "plots"
    check_output_path(out, into=True)  # under a file, /proc, read-only, too long: one line before any work
    # a file of ours by its mark; a user's changes.md or index.html in --out is refused before any work
    check_replaceable(out / "changes.md", lambda head: head.startswith(CHANGES_MARK.encode()))
    if html:
        check_replaceable(out / "index.html", lambda head: HTML_MARK.encode() in head)
    hist = load_history(history_dir, machine)
    out.mkdir(parents=True, exist_ok=True)
    pngs, cps, entries = [], [], []
    for mkey, df in hist.items():
        mdir = out / mkey
        mdir.mkdir(parents=True, exist_ok=True)
        for k, (label, p) in _series(df).items():
            n = len(p)
            x = list(range(n))
            tcp = detect_change_points(p["total_ms"], alpha=alpha, min_size=min_size,
                                       min_effect=min_effect, relative=True)
            qname = p.attrs.get("quality", "psnr")
            qcp = detect_change_points(p["psnr"], alpha=alpha, min_size=min_size,
                                       min_effect=min_db if qname == "psnr" else 0.002, relative=False)
            fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(max(6.0, 0.35 * n + 3), 6), sharex=True)
            ax1.fill_between(x, p["q1"], p["q3"], alpha=0.25, color="tab:blue", label="IQR")
            ax1.plot(x, p["total_ms"], "o-", color="tab:blue", ms=3, label="median total_ms")
            ax1.set_ylabel("frame time (ms)")
            ax1.set_title(f"{label}\n{mkey}", fontsize=9)
            ax2.plot(x, p["psnr"], "o-", color="tab:green", ms=3, label=qname)
            ax2.set_ylabel("PSNR (dB)" if qname == "psnr" else qname)
            for i in range(1, n):
                if p["params"].iloc[i] != p["params"].iloc[i - 1]:
                    for ax in (ax1, ax2):
                        ax.axvline(i - 0.5, color="0.5", ls=":", lw=1)
                    ax2.annotate("params", (i - 0.5, 0.02), xycoords=("data", "axes fraction"),
                                 ha="left", va="bottom", fontsize=7, color="0.4")
            failed = [i for i, s in enumerate(p["status"]) if s != "ok"]
            for i in failed:
                for ax in (ax1, ax2):
                    ax.axvspan(i - 0.5, i + 0.5, color="tab:red", alpha=0.12, lw=0)
            for c in tcp:
                ax1.axvline(c.index - 0.5, color="tab:red", ls="--", lw=1.2)
                ax1.annotate(f"{c.change:+.0%}", (c.index - 0.5, 1.0), xycoords=("data", "axes fraction"),
                             ha="left", va="top", fontsize=8, color="tab:red")
            for c in qcp:
                ax2.axvline(c.index - 0.5, color="tab:purple", ls="--", lw=1.2)
                ax2.annotate(f"{c.change:+.2f} dB" if qname == "psnr" else f"{c.change:+.3g}",
                             (c.index - 0.5, 1.0), xycoords=("data", "axes fraction"),
                             ha="left", va="top", fontsize=8, color="tab:purple")
            ticks = [f"{c}\n{t[5:10]}" for c, t in zip(p["commit"], p["time"])]
            step = max(1, n // 25)
            ax2.set_xticks(x[::step])
            ax2.set_xticklabels(ticks[::step], fontsize=7, rotation=90)
            ax2.set_xlabel("run (commit, date)")
            ax1.legend(fontsize=7, loc="best")
            for ax in (ax1, ax2):
                ax.grid(alpha=0.3)
            fig.tight_layout()
            path = mdir / f"{slug(label, 120, fallback='benchmark')}.png"
            check_replaceable(path, lambda head: PNG_MARK.encode() in head)  # PNG text chunks precede the pixels
            atomic_write(path, lambda t: fig.savefig(t, dpi=100, format="png", metadata={"Software": PNG_MARK}))
            plt.close(fig)
            pngs.append(path)
            entries.append({"machine": mkey, "benchmark": label, "png": path, "points": p, "quality": qname,
                            "changes": len(tcp) + len(qcp)})
            for metric, lst in (("total_ms", tcp), (qname, qcp)):
                for c in lst:
                    r = p.iloc[c.index]
                    cps.append({"machine": mkey, "benchmark": label, "metric": metric, "index": c.index,
                                "run_id": r["run_id"], "commit": r["commit"], "time": r["time"],
                                "before": c.before, "after": c.after, "change": c.change, "p": c.p,
                                "png": path})
    changes = out / "changes.md"
    atomic_write_text(changes, _changes_md(cps, alpha, min_effect, min_db, min_size, out))
    index = None
    if html:
        index = out / "index.html"
        atomic_write_text(index, _index_html(entries, cps, out, alpha, min_effect, min_db, min_size))
    return {"pngs": pngs, "changes": changes, "change_points": cps, "html": index}


_CSS = """body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}h1{font-size:1.4em}
h2{font-size:1.15em;margin-top:1.6em;border-bottom:1px solid #ccc}.grid{display:flex;flex-wrap:wrap;gap:12px}
.card{border:1px solid #ddd;border-radius:4px;padding:6px;width:320px;font-size:.8em}
.card img{width:100%;height:auto;display:block}.card .name{font-weight:600;word-break:break-word}
.changed{border-color:#c33}.badge{color:#c33;font-weight:600}table{border-collapse:collapse;font-size:.85em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}input{margin:.5em 0;padding:3px;width:20em}"""

_FILTER_JS = """function f(q){q=q.toLowerCase();document.querySelectorAll('.card').forEach(function(c){
c.style.display=c.dataset.name.indexOf(q)<0?'none':''})}"""


def _fmt_last(v, unit="") -> str:
    return "—" if v is None or not math.isfinite(v) else f"{v:.4g}{unit}"


def _index_html(entries, cps, out: Path, alpha, min_effect, min_db, min_size) -> str:
    """The static page over all machines and benchmarks (relative links into ``out``)."""
    def rel(path) -> str:
        return escape(Path(os.path.relpath(path, out)).as_posix(), quote=True)

    machines = list(dict.fromkeys(e["machine"] for e in entries))
    n_runs = max((len(e["points"]) for e in entries), default=0)
    lines = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">', HTML_MARK,
             "<title>ldbench history</title>", f"<style>{_CSS}</style>", f"<script>{_FILTER_JS}</script>",
             "</head><body>", "<h1>ldbench benchmark history</h1>",
             f"<p>{len(entries)} benchmark(s) on {len(machines)} machine(s), up to {n_runs} run(s) each, in "
             "commit order (oldest left). Each plot: median frame time with its interquartile band (top) and "
             "quality (bottom); dashed lines are detected change points (two-sided Mann-Whitney U, "
             f"Bonferroni p &lt; {alpha:g}, at least {min_size} runs each side, shift ≥ {min_effect:.0%} "
             f"in time or {min_db:g} dB in PSNR). Details: <a href=\"changes.md\">changes.md</a>.</p>",
             '<input type="search" placeholder="filter benchmarks" oninput="f(this.value)">']
    for m in machines:
        lines += [f'<h2 id="{escape(m, quote=True)}">{escape(m)}</h2>', '<div class="grid">']
        for e in (e for e in entries if e["machine"] == m):
            p = e["points"]
            last = p.iloc[-1]
            q = e["quality"]
            qv = _fmt_last(float(last["psnr"]), " dB" if q == "psnr" else "")
            badge = f' <span class="badge">{e["changes"]} change(s)</span>' if e["changes"] else ""
            cls = "card changed" if e["changes"] else "card"
            lines.append(
                f'<div class="{cls}" data-name="{escape(e["benchmark"].lower(), quote=True)}">'
                f'<a href="{rel(e["png"])}"><img src="{rel(e["png"])}" loading="lazy" '
                f'alt="{escape(e["benchmark"], quote=True)}"></a>'
                f'<div class="name">{escape(e["benchmark"])}</div>'
                f"<div>{len(p)} run(s); latest {escape(str(last['commit']))} {escape(str(last['time'])[:10])}: "
                f"{_fmt_last(float(last['total_ms']), ' ms')}, {escape(q)} {qv}{badge}</div></div>")
        lines.append("</div>")
    lines.append("<h2>Change points</h2>")
    if not cps:
        lines.append("<p>No change points.</p>")
    else:
        lines.append("<table><tr><th>machine</th><th>benchmark</th><th>metric</th><th>first run after</th>"
                     "<th>commit</th><th>date</th><th>before</th><th>after</th><th>change</th><th>p</th></tr>")
        for c in cps:
            t = c["metric"] == "total_ms"
            ch = f"{c['change']:+.1%}" if t else f"{c['change']:+.3g}"
            lines.append("<tr>" + "".join(f"<td>{escape(str(x))}</td>" for x in (
                c["machine"], c["benchmark"], c["metric"], c["run_id"], c["commit"], c["time"][:10],
                f"{c['before']:.4g}", f"{c['after']:.4g}", ch, f"{c['p']:.2g}")) + "</tr>")
        lines.append("</table>")
    lines.append("</body></html>")
    return "\n".join(lines) + "\n"


#: What marks the files ``plot_history`` writes as its own (it replaces those, and refuses any other file).
CHANGES_MARK = "# Detected changes"
HTML_MARK = '<meta name="generator" content="ldbench history plot">'
PNG_MARK = "ldbench history plot"


def _changes_md(cps, alpha, min_effect, min_db, min_size, out) -> str:
    lines = [CHANGES_MARK, "",
             f"Binary segmentation with a two-sided Mann-Whitney U test (Bonferroni-corrected p < {alpha:g}, "
             f"at least {min_size} runs on each side) and a minimum median shift of {min_effect:.0%} "
             f"(time) or {min_db:g} dB (PSNR).", ""]
    if not cps:
        lines.append("No change points.")
        return "\n".join(lines) + "\n"
    lines += ["| machine | benchmark | metric | first run after | commit | date | before | after | change | p | plot |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cps:
        if c["metric"] == "total_ms":
            b, a, ch = f"{c['before']:.3g} ms", f"{c['after']:.3g} ms", f"{c['change']:+.1%}"
        else:
            b, a, ch = f"{c['before']:.2f} dB", f"{c['after']:.2f} dB", f"{c['change']:+.2f} dB"
        rel = os.path.relpath(c["png"], out)
        lines.append(f"| {c['machine']} | {c['benchmark']} | {c['metric']} | {c['run_id']} | {c['commit']} "
                     f"| {c['time'][:10]} | {b} | {a} | {ch} | {c['p']:.2g} | [png]({rel}) |")
    return "\n".join(lines) + "\n"


def run_plot(args) -> int:
    """``ldbench history plot``."""
    res = plot_history(args.history_dir, args.out, machine=args.machine, alpha=args.alpha,
                       min_effect=args.min_effect, min_db=args.min_db, min_size=args.min_size,
                       html=args.html)
    print(f"history: {len(res['pngs'])} plot(s), {len(res['change_points'])} change point(s)")
    for c in res["change_points"]:
        ch = f"{c['change']:+.1%}" if c["metric"] == "total_ms" else f"{c['change']:+.2f} dB"
        print(f"  {c['benchmark']} [{c['metric']}] {ch} at {c['commit']} ({c['time'][:10]})")
    print(f"wrote {res['changes']}" + (f" and {res['html']}" if res["html"] else ""))
    return 0
