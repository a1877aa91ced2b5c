"""``ldbench compare BASELINE RUN``: the command's run (reports written, exit status); its arguments are
:mod:`~ldbench.harness.compare.arguments`."""
from __future__ import annotations

import json
import logging
from pathlib import Path

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write_text, check_replaceable

from .gate import compare_paths
from .match import parse_match
from .render import JSON_FORMAT, summary_text, to_json, to_markdown
from .verdicts import Thresholds

log = logging.getLogger(__name__)

def _ours_md(head: bytes) -> bool:
    return head.startswith(b"## ldbench compare:")


def _ours_json(head: bytes) -> bool:
    return head.lstrip().startswith(b"{") and f'"format": "{JSON_FORMAT}"'.encode() in head


def _write_text(path: Path, text: str, ours):
    """Write ``text`` to ``path`` through a temporary file and a rename (no half-written report); an existing
    file is replaced only where ``ours`` recognises an earlier report of the same kind."""
    check_replaceable(path, ours)
    try:
        atomic_write_text(path, text)
    except OSError as e:
        raise LdbenchError(f"cannot write {path}: {e.strerror or e}")


def run_cli(args) -> int:
    th = Thresholds(alpha=args.alpha, min_effect=args.min_effect, tol_db=args.tol_db,
                    ssim_tol=args.ssim_tol, noise_z=args.noise_z, allow_missing=args.allow_missing,
                    time=not args.no_time, cpu_time=args.cpu_time,
                    allow_nan_baseline=args.allow_nan_baseline)
    match = parse_match(args.match)
    comp = compare_paths(args.baseline, args.run, match=match, thresholds=th)
    run_path = Path(args.run)
    out = Path(args.md) if args.md else (run_path if run_path.is_dir() else run_path.parent) / "compare.md"
    check_replaceable(out, _ours_md)  # both outputs checked before either is written
    if args.json:
        check_replaceable(Path(args.json), _ours_json)
    _write_text(out, to_markdown(comp), _ours_md)
    if args.json:
        _write_text(Path(args.json), json.dumps(to_json(comp), indent=2, allow_nan=False) + "\n", _ours_json)
    for w in comp.warnings:
        log.warning(w)
    print(summary_text(comp))
    print(f"wrote {out}" + (f" and {args.json}" if args.json else ""))
    return comp.exit_code
