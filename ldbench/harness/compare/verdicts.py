"""The gate's settings and its answers: :class:`Thresholds`, one :class:`Check` per metric of a benchmark,
the whole :class:`Comparison`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ldbench.core.errors import LdbenchError

from .keys import DEFAULT_MATCH

REGRESSING_VERDICTS = ("regression", "failed", "missing", "degraded", "unchecked")


@dataclass
class Thresholds:
    """Gate settings (the CLI flags of the same names)."""
    alpha: float = 0.01        # significance of the one-sided Mann-Whitney U test
    min_effect: float = 0.10   # minimum relative slow-down of the median to count
    tol_db: float = 0.5        # PSNR drop always tolerated (dB)
    ssim_tol: float = 0.01     # SSIM drop always tolerated
    noise_z: float = 3.0       # standard deviations of reference noise tolerated (see noise_bound)
    allow_missing: bool = False
    time: bool = True          # False: skip time checks (--no-time)
    cpu_time: bool = False     # True: gate time on cpu-software (llvmpipe) too (--cpu-time)
    allow_nan_baseline: bool = False  # True: a NaN quality metric of the baseline does not fail

    def validate(self):
        if not 0 < self.alpha < 1:
            raise LdbenchError(f"--alpha must be in (0, 1), got {self.alpha}")
        for name in ("min_effect", "tol_db", "ssim_tol", "noise_z"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise LdbenchError(f"--{name.replace('_', '-')} must be a finite number >= 0, got {v}")
        return self


@dataclass
class Check:
    benchmark: str
    metric: str            # "time", "psnr", "ssim", "status"
    baseline: str
    current: str
    change: str
    verdict: str           # ok | regression | improved | inconclusive | skipped | failed | missing | new | fixed
    #                        | unchecked (the baseline's metric is NaN: nothing to compare against) | n/a
    note: str = ""

    @property
    def regression(self) -> bool:
        return self.verdict in REGRESSING_VERDICTS


@dataclass
class Comparison:
    checks: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    notes: list = field(default_factory=list)    # per-benchmark remarks (differing configurations, ...)
    match: tuple = DEFAULT_MATCH
    thresholds: Thresholds = field(default_factory=Thresholds)
    baseline_label: str = ""
    run_label: str = ""
    matched: int = 0
    rows: dict = field(default_factory=dict)  # benchmark label -> (baseline row, run row), for to_json

    @property
    def regressions(self) -> list:
        return [c for c in self.checks if c.regression]

    @property
    def exit_code(self) -> int:
        return 1 if self.regressions else 0

    def count(self, verdict: str) -> int:
        return sum(c.verdict == verdict for c in self.checks)
