"""``ldbench compare``'s arguments. Apart from the command (:mod:`~ldbench.harness.compare.command`), which
imports pandas and scipy: every ``ldbench`` invocation builds this parser, and those imports took 0.75 of
the CLI's 1.2 s start."""
from __future__ import annotations

from .keys import DEFAULT_MATCH, MATCH_KEYS
from .verdicts import Thresholds


def add_arguments(p):
    p.add_argument("baseline", help="baseline run directory or results.parquet/.csv")
    p.add_argument("run", help="current run directory or results.parquet/.csv")
    p.add_argument("--match", default=None, metavar="KEYS",
                   help=f"comma-separated match keys (default: {','.join(DEFAULT_MATCH)}; "
                        f"known: {','.join(MATCH_KEYS)})")
    p.add_argument("--alpha", type=float, default=Thresholds.alpha,
                   help="significance of the one-sided Mann-Whitney U test on frame times (default 0.01)")
    p.add_argument("--min-effect", type=float, default=Thresholds.min_effect,
                   help="minimum relative slow-down of the median frame time (default 0.10 = 10%%)")
    p.add_argument("--tol-db", type=float, default=Thresholds.tol_db,
                   help="PSNR drop always tolerated, dB (default 0.5)")
    p.add_argument("--ssim-tol", type=float, default=Thresholds.ssim_tol,
                   help="SSIM drop always tolerated (default 0.01)")
    p.add_argument("--noise-z", type=float, default=Thresholds.noise_z,
                   help="reference-noise bound in standard deviations (default 3)")
    p.add_argument("--allow-missing", action="store_true", help="rows that vanished do not fail")
    p.add_argument("--no-time", action="store_true", help="skip time checks (quality only)")
    p.add_argument("--allow-nan-baseline", action="store_true",
                   help="a quality metric that is NaN in the baseline (nothing to compare against) does not fail")
    p.add_argument("--cpu-time", action="store_true",
                   help="gate time on a software rasterizer (cpu-software) too; off by default")
    p.add_argument("--md", "--out", dest="md", default=None, metavar="FILE",
                   help="write the Markdown report here (default: compare.md in RUN's directory)")
    p.add_argument("--json", dest="json", default=None, metavar="FILE",
                   help="also write the verdicts as JSON for CI: per check the match key, metric, baseline, "
                        "current, verdict and thresholds, and the exit status")
