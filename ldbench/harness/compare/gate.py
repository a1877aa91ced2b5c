"""The comparison of two runs: every matched benchmark's status, time and quality checks
(:func:`compare_frames`, :func:`compare_paths`); the rules are those of :mod:`ldbench.harness.compare`."""
from __future__ import annotations

import math

from ldbench.core.device import timing_fields
from ldbench.core.effects import registry
from ldbench.core.errors import LdbenchError

from .match import (DEFAULT_MATCH, MATCH_KEYS, as_float, benchmark_labels, config_diff, index_rows,
                    load_results, row_value, run_label)
from .stats import frame_samples, metric_check, psnr_check, quality_thresholds, ssim_check, time_check
from .verdicts import Check, Comparison, Thresholds

def machine_diff(brow, rrow) -> list:
    """``[(field, baseline value, run value)]`` for the machine fields that differ
    (:func:`ldbench.core.device.timing_fields`: the CPU too where it is the device)."""
    out = []
    for f in timing_fields(row_value(brow, "device"), row_value(rrow, "device")):
        bv, rv = row_value(brow, f), row_value(rrow, f)
        if (bv or None) != (rv or None):
            out.append((f, bv, rv))
    return out



def _fmt_ms(v):
    return "—" if v is None or math.isnan(v) else f"{v:.4g} ms"


def compare_frames(base, run, *, match=DEFAULT_MATCH, thresholds: Thresholds | None = None) -> Comparison:
    """Compare two results DataFrames (as from :func:`ldbench.harness.records.read_results`); the rules are
    those of :mod:`ldbench.harness.compare`."""
    th = (thresholds or Thresholds()).validate()
    match = tuple(match)
    for k in match:
        if k not in MATCH_KEYS:
            raise LdbenchError(f"unknown match key {k!r} (known: {', '.join(MATCH_KEYS)})")
    bidx = index_rows(base, match, "baseline")
    ridx = index_rows(run, match, "run")
    union = {**{k: v for k, v in ridx.items()}, **{k: v for k, v in bidx.items() if k not in ridx}}
    labels = benchmark_labels(union)
    comp = Comparison(match=match, thresholds=th)
    comp.rows = {labels[k]: (bidx.get(k), ridx.get(k)) for k in union}
    machine_warned: set[object] = set()  # "cpu", and the machine differences already warned of
    nan_base: list = []  # benchmarks whose baseline has a NaN quality metric

    order = list(bidx) + [k for k in ridx if k not in bidx]
    for k in order:
        name = labels[k]
        brow, rrow = bidx.get(k), ridx.get(k)
        if rrow is None:
            comp.checks.append(Check(name, "status", str(row_value(brow, "status")), "—", "row vanished",
                                     "missing" if not th.allow_missing else "n/a",
                                     "allowed by --allow-missing" if th.allow_missing else ""))
            continue
        if brow is None:
            comp.checks.append(Check(name, "status", "—", str(row_value(rrow, "status")), "new row", "new"))
            continue
        comp.matched += 1
        diff = config_diff(brow, rrow)
        if diff:
            comp.notes.append(f"{name}: {diff}")
        bstat, rstat = str(row_value(brow, "status") or "?"), str(row_value(rrow, "status") or "?")
        if rstat != "ok":
            comp.checks.append(Check(name, "status", bstat, rstat, "",
                                     "degraded" if rstat.startswith("degraded") else "failed"))
            continue
        if bstat != "ok":
            comp.checks.append(Check(name, "status", bstat, rstat, "baseline had failed", "fixed"))
            continue

        # time
        md = machine_diff(brow, rrow)
        tb, tr = as_float(row_value(brow, "total_ms")), as_float(row_value(rrow, "total_ms"))
        if not th.time:
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped", "--no-time"))
        elif (not th.cpu_time and row_value(brow, "device") == "cpu-software"
              and row_value(rrow, "device") == "cpu-software"):
            if "cpu" not in machine_warned:
                machine_warned.add("cpu")
                comp.warnings.append("software rasterizer (cpu-software): frame times are wall clock on "
                                     "shared CPU cores and vary between runs far more than within a run; "
                                     "time checks are off (--cpu-time turns them on), quality is gated")
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped", "cpu-software"))
        elif md:
            sig = tuple(md)
            if sig not in machine_warned:
                machine_warned.add(sig)
                comp.warnings.append("machine differs (" + "; ".join(
                    f"{f}: {bv!r} → {rv!r}" for f, bv, rv in md) + "): time checks are off, quality is "
                    "still gated")
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), "", "skipped",
                                     "machine differs"))
        else:
            t = time_check(frame_samples(brow), frame_samples(rrow), th)
            if t["verdict"] in ("n/a", "inconclusive"):
                change = "" if math.isnan(t["change"]) else f"{t['change']:+.1%}"
            else:
                p = t["p"] if t["verdict"] != "improved" else t["p_faster"]
                change = f"{t['change']:+.1%} (p={p:.2g})"
            comp.checks.append(Check(name, "time", _fmt_ms(tb), _fmt_ms(tr), change, t["verdict"], t["note"]))

        # quality
        gate = gated_metrics(rrow)
        if gate:
            checks = [metric_check(name, brow, rrow, *g) for g in gate]
            compared = any(c.verdict != "n/a" for c in checks)
            for i, c in enumerate(checks):  # a NaN baseline judges nothing: say so (both NaN: undefined here)
                if c.baseline == "NaN" and (c.current != "NaN" or not compared):
                    checks[i] = _nan_baseline(name, c.metric, c.current, th)
                    nan_base += [name] if name not in nan_base else []
            comp.checks += checks
            continue
        q = quality_thresholds(brow, rrow, th)
        pb, pr = as_float(row_value(brow, "psnr")), as_float(row_value(rrow, "psnr"))
        sb, sr = as_float(row_value(brow, "ssim")), as_float(row_value(rrow, "ssim"))
        if pb is None or math.isnan(pb) or sb is None or math.isnan(sb):
            nan_base.append(name)
        if pb is None or math.isnan(pb):
            comp.checks.append(_nan_baseline(name, "psnr", _fmt_db(pr), th))
        v, change, _ = psnr_check(pb, pr, q, th)
        if v != "n/a":
            notes = [] if q["noise_known"] else ["reference noise unknown"]
            if row_value(brow, "scene_hash") != row_value(rrow, "scene_hash"):
                notes.append("scene differs")
            elif not q["same_reference"]:
                notes.append("references differ")
            note = "; ".join(notes)
            comp.checks.append(Check(name, "psnr", _fmt_db(pb), _fmt_db(pr), change, v, note))
        if sb is None or math.isnan(sb):
            comp.checks.append(_nan_baseline(name, "ssim", _fmt_num(sr), th))
        v, change, _ = ssim_check(sb, sr, q, th)
        if v != "n/a":
            comp.checks.append(Check(name, "ssim", _fmt_num(sb), _fmt_num(sr), change, v))
    if nan_base:
        comp.warnings.append(
            f"the baseline has NaN quality metrics for {len(nan_base)} benchmark(s) ({nan_base[0]}"
            + (", ..." if len(nan_base) > 1 else "") + "): nothing to compare them against; "
            + ("allowed by --allow-nan-baseline" if th.allow_nan_baseline
               else "they fail unless --allow-nan-baseline"))
    return comp


def _nan_baseline(name, metric, current, th) -> Check:
    """The check of a metric the baseline holds as NaN (a broken baseline): ``unchecked`` (failing), or
    ``n/a`` with ``--allow-nan-baseline``."""
    if th.allow_nan_baseline:
        return Check(name, metric, "NaN", current, "", "n/a", "baseline NaN, allowed by --allow-nan-baseline")
    return Check(name, metric, "NaN", current, "baseline NaN", "unchecked", "nothing to compare against")


def gated_metrics(row) -> tuple:
    """The effect's gated metrics (non-image effects), () for image effects and unknown effects."""
    spec = registry().get(str(row_value(row, "effect")))
    return tuple(spec.gate) if spec is not None else ()



def _fmt_db(v):
    if v is None or math.isnan(v):
        return "NaN"
    return "∞ dB" if math.isinf(v) else f"{v:.2f} dB"


def _fmt_num(v):
    return "NaN" if v is None or math.isnan(v) else f"{v:.4f}"



def compare_paths(baseline, run, *, match=DEFAULT_MATCH, thresholds: Thresholds | None = None) -> Comparison:
    """Load two runs (directories or results files) and compare them."""
    base_df = load_results(baseline, "baseline", match)
    run_df = load_results(run, "run", match)
    comp = compare_frames(base_df, run_df, match=match, thresholds=thresholds)
    comp.baseline_label = run_label(base_df, baseline)
    comp.run_label = run_label(run_df, run)
    return comp
