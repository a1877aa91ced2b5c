"""Benchmark history: ``ldbench history add RUN`` and ``ldbench history plot`` (docs/how-to/nightly-ci.md).

Storage
    ``<history-dir>/<machine-key>.parquet``, one file per machine (:func:`ldbench.harness.records.machine_key`
    of device, GL renderer and driver: timings of different machines never share a series). The
    files hold the result rows exactly as ``results.parquet`` does (JSON columns as JSON text, the
    ``machine_key`` column filled in), sorted by time. Adding a run replaces any rows with the same
    ``run_id`` first, so adding a run twice is idempotent. Writers take ``<history-dir>/.lock``
    (``flock``; concurrent ``history add`` wait their turn, at most :data:`LOCK_WAIT_S`) and replace
    each file atomically, so every added run's rows are kept and a reader never sees a torn file.
    The default history directory is ``history/`` under the current directory; it is meant to live
    outside git (a CI cache or artifact, see ``docs/how-to/nightly-ci.md``), add ``/history/`` to ``.gitignore``
    if you keep one locally.

Plots (:mod:`ldbench.reports.history_plots`)
    One PNG per machine and benchmark (benchmarks as in
    :data:`ldbench.harness.compare.match.DEFAULT_MATCH`): the median frame time ``total_ms`` with its
    interquartile band (from the raw samples) and the
    quality (PSNR; for a non-image effect the first metric it gates, e.g. ``rays``: hit agreement, with
    an absolute change floor of 0.002), one point per run in time order, the x axis labelled with the short commit (``*`` = dirty
    checkout) and date. Detected change points are drawn as vertical lines and listed in
    ``changes.md``. ``index.html`` beside them is a static page of every machine's benchmarks (small
    plots linking to the full PNGs, the latest values, the change points), offline: no scripts or
    styles from elsewhere, so it can be opened from disk or published as a CI artifact.

Change-point detection (:func:`detect_change_points`)
    Binary segmentation with a rank test. For a segment of the series, every split ``k`` leaving at
    least ``min_size`` points on each side is scored with a two-sided Mann-Whitney U test of the
    points before against the points after; the best split is accepted when its Bonferroni-corrected
    p-value (p times the number of candidate splits) is below ``alpha / 2`` **and** its median
    shift is at least ``min_effect`` (relative for times, default 10 %; absolute for PSNR, default
    0.5 dB). If no single split qualifies, the same test is run on every middle interval against the
    points around it (a regression that was later fixed), again with Bonferroni and ``alpha / 2``.
    The parts are then searched the same way. The rank test is robust to outlier nights; Bonferroni
    keeps the false-alarm rate of each segment search at most ``alpha`` on pure noise; the effect
    floor ignores shifts too small to matter. A step is found once enough runs lie on both sides of
    it: with the defaults (``alpha`` 0.01, ``min_size`` 3) a clean step needs about 6 runs after it
    in a 16-run series (4 after 30 runs, 6 after 10): a regression shows up in the plots within a
    week of nightlies; the gate (``ldbench compare``) catches it the first night.
"""
from __future__ import annotations

import fcntl
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write, check_output_path

# Start-up: the CLI imports this module while it builds its parser, so records (about 7 ms) is imported where used;
# compare.match (pandas) and scipy are heavy.

DEFAULT_HISTORY_DIR = "history"
LOCK_NAME = ".lock"
#: How long ``history add`` waits for another writer of the same history directory.
LOCK_WAIT_S = 300.0


# --------------------------------------------------------------------------------------------------
# storage


def row_machine_key(row) -> str:
    """The row's ``machine_key``, else computed from its ``machine`` dict or machine columns."""
    from . import records
    from .compare.match import row_value

    k = row_value(row, "machine_key")
    if k:
        return str(k)
    m = row_value(row, "machine")
    if isinstance(m, dict) and any(m.get(f) for f in ("device", "gl_renderer", "driver")):
        return records.machine_key(m)
    return records.machine_key({f: row_value(row, f) for f in ("device", "gl_renderer", "driver")})


def _serialize(df):
    """Parsed results (JSON columns as Python objects) back to their stored form (JSON text)."""
    import pandas as pd
    from .records import JSON_COLUMNS, to_json

    out = df.copy()
    for c in JSON_COLUMNS:
        if c in out:
            out[c] = pd.Series([to_json(v) if isinstance(v, (dict, list)) else (None if v is None else v)
                                for v in out[c]], index=out.index, dtype=object)
    return out


def _sort(df):
    return df.sort_values(["time", "run_id"], kind="stable", na_position="first").reset_index(drop=True)


class _Lock:
    """``with _Lock(hdir):`` holds ``hdir/.lock`` exclusively (``flock``, dropped by the kernel if the
    holder dies), waiting at most :data:`LOCK_WAIT_S` for another writer."""

    def __init__(self, hdir: Path):
        self.path = hdir / LOCK_NAME
        self.fd = None

    def __enter__(self):
        try:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise LdbenchError(f"cannot write to history directory {self.path.parent}: {e.strerror or e}")
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    os.close(self.fd)
                    raise LdbenchError(f"history directory {self.path.parent} is locked by another writer "
                                       f"for more than {LOCK_WAIT_S:.0f} s ({self.path})") from None
                time.sleep(0.05)
        return self

    def __exit__(self, *exc):
        os.close(self.fd)  # releases the lock; the file stays (deleting it would race a waiting writer)
        return False


def add_run(run, history_dir=DEFAULT_HISTORY_DIR) -> list[dict]:
    """Append a run's rows to the per-machine history files (replacing rows of the same run_id).

    Returns one dict per machine touched: ``{"machine_key", "path", "added", "rows", "runs"}``.
    """
    from .compare.match import load_results

    check_output_path(history_dir, into=True, flag="--history-dir")  # before reading the run
    df = load_results(run, "run")
    if "run_id" not in df or df["run_id"].isna().any():
        raise LdbenchError(f"run {run} has rows without a run_id")
    df = df.copy()
    df["machine_key"] = [row_machine_key(r) for _, r in df.iterrows()]
    hdir = Path(history_dir)
    try:
        hdir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise LdbenchError(f"cannot create history directory {hdir}: {e.strerror or e}")
    with _Lock(hdir):
        return [_add_group(hdir, key, group) for key, group in df.groupby("machine_key", sort=True)]


def _add_group(hdir: Path, key: str, group) -> dict:
    """Merge one machine's rows into its history file (call with the lock held)."""
    import pandas as pd

    from .records import check_columns

    path = hdir / f"{key}.parquet"
    new = _serialize(group)
    ids = set(new["run_id"])
    if path.exists():
        try:
            old = pd.read_parquet(path, engine="pyarrow")
        except Exception as e:  # a corrupt history file must not be silently overwritten
            why = (str(e).strip().splitlines() or [type(e).__name__])[0][:200]
            raise LdbenchError(f"cannot read history file {path}: {why}")
        check_columns(old.columns, f"history file {path}")
        old = old[~old["run_id"].isin(ids)]
        both = pd.concat([old, new], ignore_index=True) if len(old) else new
    else:
        both = new
    both = _sort(both)
    atomic_write(path, lambda t: both.to_parquet(t, index=False, engine="pyarrow"))
    return {"machine_key": key, "path": path, "added": len(new), "rows": len(both),
            "runs": int(both["run_id"].nunique())}


def load_history(history_dir=DEFAULT_HISTORY_DIR, machine: str | None = None) -> dict:
    """``{machine_key: DataFrame}`` of the history files (JSON columns parsed), sorted by time."""
    from .records import read_results

    hdir = Path(history_dir)
    if not hdir.is_dir():
        raise LdbenchError(f"history directory not found: {hdir}")
    files = sorted(hdir.glob("*.parquet"))
    if machine is not None:
        files = [f for f in files if f.stem == machine]
        if not files:
            known = ", ".join(f.stem for f in sorted(hdir.glob("*.parquet"))) or "none"
            raise LdbenchError(f"no history for machine {machine!r} in {hdir} (known: {known})")
    if not files:
        raise LdbenchError(f"no history files (*.parquet) in {hdir}; add runs with 'ldbench history add'")
    return {f.stem: _sort(read_results(f)) for f in files}


# --------------------------------------------------------------------------------------------------
# change points


@dataclass
class ChangePoint:
    index: int          # first point after the change
    p: float            # Bonferroni-corrected p-value
    before: float       # median of the segment before
    after: float        # median of the segment after
    change: float       # after/before - 1 (relative) or after - before (absolute)


def _shift(left, right, relative: bool) -> float:
    mb, ma = float(np.median(left)), float(np.median(right))
    if relative:
        return ma / mb - 1.0 if mb != 0 else (0.0 if ma == 0 else math.inf)
    return ma - mb


def _rank_z(ranks, ties_term, i, j):
    """Normal-approximation z of the Mann-Whitney U statistic of the points ``[i, j)`` of a segment
    against the rest of it, for arrays of interval bounds ``i``, ``j`` (vectorized)."""
    n = ranks.size
    c = np.concatenate([[0.0], np.cumsum(ranks)])
    n1 = (j - i).astype(float)
    n2 = n - n1
    u = c[j] - c[i] - n1 * (n1 + 1) / 2
    var = n1 * n2 / 12.0 * ((n + 1) - ties_term / (n * (n - 1)))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(var > 0, (u - n1 * n2 / 2) / np.sqrt(var), 0.0)


def detect_change_points(y, *, alpha: float = 0.01, min_size: int = 3, min_effect: float = 0.10,
                         relative: bool = True) -> list[ChangePoint]:
    """Change points of a series by binary segmentation with a Mann-Whitney U test.

    For a segment ``y[a:b]`` (initially the whole series):

    1. *Single split.* Every ``k`` with at least ``min_size`` points on each side is scored by the
       Mann-Whitney U statistic of ``y[a:k]`` against ``y[k:b]`` (normal approximation with tie
       correction, vectorized over ``k`` from one ranking). The best split's exact two-sided p-value
       (:func:`scipy.stats.mannwhitneyu`) times the number of candidates (Bonferroni) must be below
       ``alpha / 2``, and its median shift at least ``min_effect``.
    2. *Epidemic change* (only if 1 found nothing): a regression that was later fixed, or a
       temporary improvement, is a middle interval ``y[i:j]`` that differs from the points around it,
       which no single split separates well. Every interval with ``min_size`` points inside and on
       either side is scored against the rest of the segment in the same way, with Bonferroni over
       the intervals and ``alpha / 2``; its two ends are change points.
    3. Accepted points split the segment, and the parts are searched again.

    The false-alarm probability of each segment search on pure noise is thus at most ``alpha``
    (Bonferroni is conservative: the candidate tests are positively correlated). The rank test is
    robust to outlier nights; the effect-size floor ignores shifts too small to matter.

    Parameters
    ----------
    y : sequence of float
        The series in time order; NaN points are ignored (indices refer to the original series).
    alpha : float
        Family-wise significance per segment.
    min_size : int
        Minimum number of points on each side of a change.
    min_effect : float
        Minimum median shift: relative (``after/before - 1``) if ``relative``, else absolute.

    Returns
    -------
    list of ChangePoint (``index`` = first point after the change), sorted by index.
    """
    from scipy.stats import mannwhitneyu, rankdata

    y = np.asarray(list(y), float)
    keep = np.flatnonzero(np.isfinite(y))
    v = y[keep]
    min_size = max(int(min_size), 1)
    found: list[ChangePoint] = []

    def point(k, lo, hi, p):
        before, after = v[lo:k], v[k:hi]
        found.append(ChangePoint(int(keep[k]), p, float(np.median(before)), float(np.median(after)),
                                 _shift(before, after, relative)))

    def search(a, b):
        seg = v[a:b]
        n = b - a
        if n < 2 * min_size or np.ptp(seg) == 0:
            return
        ranks = rankdata(seg)
        _, counts = np.unique(seg, return_counts=True)
        ties = float(np.sum(counts.astype(float) ** 3 - counts))
        # 1. single split at k (local index): [0, k) against [k, n)
        ks = np.arange(min_size, n - min_size + 1)
        z = _rank_z(ranks, ties, np.zeros_like(ks), ks)
        k = int(ks[np.argmax(np.abs(z))])
        p = float(mannwhitneyu(seg[:k], seg[k:], alternative="two-sided").pvalue) * ks.size
        if min(p, 1.0) < alpha / 2 and abs(_shift(seg[:k], seg[k:], relative)) >= min_effect:
            point(a + k, a, b, min(p, 1.0))
            search(a, a + k)
            search(a + k, b)
            return
        # 2. epidemic change: [i, j) against [0, i) + [j, n)
        if n < 3 * min_size:
            return
        ii, jj = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        ok = (ii >= min_size) & (jj - ii >= min_size) & (n - jj >= min_size)
        ii, jj = ii[ok], jj[ok]
        z = _rank_z(ranks, ties, ii, jj)
        best = int(np.argmax(np.abs(z)))
        i, j = int(ii[best]), int(jj[best])
        inside, outside = seg[i:j], np.concatenate([seg[:i], seg[j:]])
        p = min(1.0, float(mannwhitneyu(inside, outside, alternative="two-sided").pvalue) * ii.size)
        if p < alpha / 2 and abs(_shift(outside, inside, relative)) >= min_effect:
            point(a + i, a, a + j, p)
            point(a + j, a + i, b, p)
            search(a, a + i)
            search(a + i, a + j)
            search(a + j, b)

    search(0, len(v))
    return sorted(found, key=lambda c: c.index)


# --------------------------------------------------------------------------------------------------
# CLI


def add_arguments(p):
    sub = p.add_subparsers(dest="history_command", required=True, parser_class=type(p))
    a = sub.add_parser("add", help="append a run's rows to the per-machine history")
    a.add_argument("run", help="run directory or results.parquet/.csv")
    a.add_argument("--history-dir", default=DEFAULT_HISTORY_DIR, help="default: history/")
    q = sub.add_parser("plot", help="plot time and PSNR over runs with detected change points")
    q.add_argument("--history-dir", default=DEFAULT_HISTORY_DIR, help="default: history/")
    q.add_argument("--out", default=None, help="output directory (default: <history-dir>/plots)")
    q.add_argument("--machine", default=None, help="only this machine key (a history file's stem)")
    q.add_argument("--alpha", type=float, default=0.01, help="change-point significance (default 0.01)")
    q.add_argument("--min-effect", type=float, default=0.10,
                   help="minimum relative time shift of a change point (default 0.10)")
    q.add_argument("--min-db", type=float, default=0.5, help="minimum PSNR shift of a change point (dB)")
    q.add_argument("--min-size", type=int, default=3, help="minimum runs on each side of a change point")
    q.add_argument("--no-html", dest="html", action="store_false",
                   help="skip index.html, the offline page of all benchmarks over commits (written by default)")


def run_add(args) -> int:
    """``ldbench history add RUN``."""
    for r in add_run(args.run, args.history_dir):
        print(f"history: {r['added']} row(s) of {args.run} → {r['path']} "
              f"({r['rows']} rows, {r['runs']} runs)")
    return 0
