"""Who wins: one leaderboard per scene, image effect and image size.

Each board ranks the configurations (a method with its parameters) of one scene × effect × size by an
error metric against the same reference, best first, with the time and memory beside it, and marks the
Pareto-optimal ones: no other configuration of the board is at least as fast and at least as accurate and
better in one of the two (:func:`ldbench.reports.figures.quality.pareto_front`). A row that failed, or whose metric
is not a finite number, is not ranked; the board lists it below the ranking with its status, so a fast
method that fails is never hidden.

Pure functions of a prepared results table (:func:`ldbench.reports.figures.table.prepare`); the report writes
the boards at the top of ``index.html`` and ``summary.md``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .figures.quality import pareto_front

#: Metrics a board can rank by: column -> higher is better
METRICS = {"psnr": True, "ssim": True, "flip": False, "relmse": False}


@dataclass(frozen=True)
class Entry:
    """One configuration of a board: ``rank`` from 1 (best), ``None`` when not ranked."""

    rank: int | None
    method: str
    params: str
    value: float
    total_ms: float
    memory_mb: float
    pareto: bool
    status: str


@dataclass
class Board:
    scene: str
    effect: str
    size: str
    metric: str
    entries: list = field(default_factory=list)  # ranked first, then the unranked in table order

    @property
    def ranked(self) -> list:
        return [e for e in self.entries if e.rank is not None]

    @property
    def unranked(self) -> list:
        return [e for e in self.entries if e.rank is None]


def _num(v) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return math.nan
    return v


def leaderboards(df, image_rows, params_label, metric: str = "psnr") -> list[Board]:
    """The boards of a prepared results table.

    Parameters
    ----------
    df : pandas.DataFrame
        rows prepared by :func:`ldbench.reports.figures.table.prepare`.
    image_rows : list of bool
        which rows are of image effects (the boards rank images only).
    params_label : callable
        row -> the configuration's non-default parameters as text.
    metric : str
        a key of :data:`METRICS`.

    Returns
    -------
    list of Board
        one per scene × effect × size, in the table's order.
    """
    if metric not in METRICS:
        raise ValueError(f"metric {metric!r} is not one of {', '.join(METRICS)}")
    higher = METRICS[metric]
    groups: dict = {}
    for (_, r), img in zip(df.iterrows(), image_rows):
        if img:
            groups.setdefault((str(r["scene"]), str(r["effect_text"]), str(r["size"])), []).append(r)
    boards = []
    for (scene, effect, size), rows in groups.items():
        ok = [r for r in rows if r["status"] == "ok" and math.isfinite(_num(r.get(metric)))]
        ok.sort(key=lambda r: (-_num(r[metric]) if higher else _num(r[metric]), _num(r["total_ms"])))
        front = set(pareto_front([_num(r["total_ms"]) for r in ok], [_num(r[metric]) for r in ok], higher))
        b = Board(scene, effect, size, metric)
        for i, r in enumerate(ok):
            b.entries.append(Entry(i + 1, str(r["method"]), params_label(r), _num(r[metric]), _num(r["total_ms"]),
                                   _num(r["memory_mb"]), i in front, str(r["status"])))
        for r in rows:
            if not any(r is o for o in ok):
                b.entries.append(Entry(None, str(r["method"]), params_label(r), _num(r.get(metric)),
                                       _num(r["total_ms"]), _num(r["memory_mb"]), False, str(r["status"])))
        boards.append(b)
    return boards
