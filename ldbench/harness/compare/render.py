"""A :class:`~ldbench.harness.compare.verdicts.Comparison` as text: the Markdown report (``compare.md``), the
JSON document (``--json``) and the terminal summary."""
from __future__ import annotations

import dataclasses
import math

from .gate import gated_metrics
from .match import as_float, plain, row_value
from .stats import quality_thresholds
from .verdicts import Check, Comparison, Thresholds

_ICON = {"regression": "❌ regression", "failed": "❌ failed", "missing": "❌ missing", "ok": "✅ ok",
         "degraded": "❌ degraded", "unchecked": "❌ unchecked",
         "improved": "🟢 improved", "new": "🆕 new", "fixed": "🟢 fixed", "skipped": "⏭ skipped",
         "inconclusive": "❔ inconclusive", "n/a": "n/a"}


def _md_cell(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def to_markdown(comp: Comparison) -> str:
    """The Markdown report: header, warnings, the table, notes."""
    th = comp.thresholds
    n_reg = len(comp.regressions)
    head = "❌ **regression**" if n_reg else "✅ **no regression**"
    lines = [f"## ldbench compare: {head}", "",
             f"- baseline: {comp.baseline_label}", f"- current: {comp.run_label}",
             f"- matched by: {', '.join(comp.match)}; {comp.matched} benchmark(s) matched, "
             f"{comp.count('missing')} missing, {comp.count('new')} new; "
             f"{n_reg} failing check(s)",
             f"- gate: time = one-sided Mann-Whitney U p < {th.alpha:g} and slow-down ≥ {th.min_effect:.0%}; "
             f"PSNR drop > max({th.tol_db:g} dB, reference noise); SSIM drop > max({th.ssim_tol:g}, "
             f"reference noise); reference noise at {th.noise_z:g} σ"
             + ("" if th.time else "; time checks off (--no-time)"), ""]
    for w in comp.warnings:
        lines.append(f"> ⚠️ **warning:** {w}")
    if comp.warnings:
        lines.append("")
    lines += ["| benchmark | metric | baseline | current | change | verdict |",
              "|---|---|---|---|---|---|"]
    for c in comp.checks:
        verdict = _ICON.get(c.verdict, c.verdict) + (f" ({c.note})" if c.note else "")
        lines.append("| " + " | ".join(_md_cell(x) for x in (c.benchmark, c.metric, c.baseline, c.current,
                                                               c.change, verdict)) + " |")
    if comp.notes:
        lines += ["", "Configurations that differ between matched rows:", ""]
        lines += [f"- {_md_cell(n)}" for n in comp.notes]
    return "\n".join(lines) + "\n"


#: Format of :func:`to_json`'s document; bumped when a field is removed or changes meaning.
JSON_FORMAT = "ldbench-compare/1"

#: The column a check's metric reads (gated metrics of non-image effects are their own column).
_METRIC_COLUMN = {"time": "total_ms", "status": "status"}


def _json_value(v):
    """A value as strict JSON: NaN -> None, ±inf -> "inf"/"-inf", numpy/pandas scalars unwrapped."""
    v = plain(v)
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {str(k): _json_value(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    return v


def _check_thresholds(c: Check, brow, rrow, th: Thresholds) -> dict:
    """The thresholds a check was judged by (recomputed from the rows, as :func:`compare_frames` does)."""
    if c.metric == "status":
        return {"allow_missing": th.allow_missing} if c.verdict in ("missing", "n/a") else {}
    if c.metric == "time":
        return {"alpha": th.alpha, "min_effect": th.min_effect, "time": th.time, "cpu_time": th.cpu_time}
    if brow is None or rrow is None:
        return {}
    if c.metric in ("psnr", "ssim"):
        q = quality_thresholds(brow, rrow, th)
        if c.metric == "psnr":
            return {"tol_db": th.tol_db, "noise_z": th.noise_z, "noise_db": q["noise_db"],
                    "allowed_drop_db": max(th.tol_db, q["noise_db"])}
        return {"ssim_tol": th.ssim_tol, "noise_z": th.noise_z, "noise_ssim": q["noise_ssim"],
                "allowed_drop": max(th.ssim_tol, q["noise_ssim"])}
    for col, better, abs_tol, rel_tol in gated_metrics(rrow):
        if col == c.metric:
            b = as_float(row_value(brow, col))
            allowed = max(abs_tol, rel_tol * abs(b)) if b is not None and math.isfinite(b) else None
            return {"better": better, "abs_tol": abs_tol, "rel_tol": rel_tol, "allowed_change": allowed}
    return {}


def to_json(comp: Comparison) -> dict:
    """The comparison as a JSON-able dict (``--json``), strict JSON (no NaN: see :func:`_json_value`).

    ``{"format", "exit_status", "regression", "baseline", "current", "match", "matched", "counts",
    "thresholds", "warnings", "notes", "checks": [{"benchmark", "key", "metric", "column", "baseline",
    "current", "baseline_text", "current_text", "change", "verdict", "regression", "note",
    "thresholds"}]}``. ``key`` holds the match keys' values of the benchmark; ``baseline`` and
    ``current`` the column's values (None where a side is missing), ``*_text`` and ``change`` what the
    Markdown table shows.
    """
    checks = []
    for c in comp.checks:
        brow, rrow = comp.rows.get(c.benchmark, (None, None))
        row = rrow if rrow is not None else brow
        col = _METRIC_COLUMN.get(c.metric, c.metric)
        checks.append({
            "benchmark": c.benchmark,
            "key": {k: _json_value(row_value(row, k)) for k in comp.match} if row is not None else {},
            "metric": c.metric, "column": col,
            "baseline": _json_value(row_value(brow, col)) if brow is not None else None,
            "current": _json_value(row_value(rrow, col)) if rrow is not None else None,
            "baseline_text": c.baseline, "current_text": c.current, "change": c.change,
            "verdict": c.verdict, "regression": c.regression, "note": c.note,
            "thresholds": _json_value(_check_thresholds(c, brow, rrow, comp.thresholds)),
        })
    counts: dict = {}
    for c in comp.checks:
        counts[c.verdict] = counts.get(c.verdict, 0) + 1
    return {"format": JSON_FORMAT, "exit_status": comp.exit_code, "regression": bool(comp.regressions),
            "baseline": comp.baseline_label, "current": comp.run_label, "match": list(comp.match),
            "matched": comp.matched, "counts": counts,
            "thresholds": _json_value(dataclasses.asdict(comp.thresholds)),
            "warnings": list(comp.warnings), "notes": list(comp.notes), "checks": checks}


def summary_text(comp: Comparison) -> str:
    """A few lines for the terminal."""
    n_reg = len(comp.regressions)
    out = [f"compare: {comp.matched} matched, {comp.count('missing')} missing, {comp.count('new')} new, "
           f"{len(comp.checks)} checks: " + (f"{n_reg} REGRESSION(S)" if n_reg else "no regression")]
    for c in comp.regressions:
        out.append(f"  {c.verdict.upper():<10} {c.benchmark} [{c.metric}] {c.baseline} → {c.current} "
                   f"{c.change}".rstrip() + (f" ({c.note})" if c.note else ""))
    imp = [c for c in comp.checks if c.verdict in ("improved", "fixed")]
    if imp:
        out.append(f"  {len(imp)} improved check(s)")
    return "\n".join(out)
