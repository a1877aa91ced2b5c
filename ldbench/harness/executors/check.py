"""Do two runs of the same suite agree? (A Ray run against a serial one: tests/test_executor_ray.py.)

Everything must be equal except :data:`TIMED` (the run's identity, times and timing-derived rates, the
machine dict with its clocks, and the device a job ran on): every other column, row by row in suite
order, and every file under ``images/`` byte for byte. ``python -m ldbench.harness.executors.check A B`` prints
the differences (none: exit 0).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from ..records import read_results

#: Columns that legitimately differ between two runs of the same jobs.
TIMED = frozenset({"run_id", "time", "total_ms", "total_ms_iqr", "wall_ms", "stage_ms", "stage_iqr", "raw_ms",
                   "rays_per_s", "oracle_rays_per_s", "machine", "egl_device", "cuda_device", "pci_bus_id"})


def _text(values) -> str:
    return json.dumps(list(values), default=str)  # NaN == NaN, dicts compared as stored


def image_files(run) -> dict:
    run = Path(run)
    return {p.relative_to(run).as_posix(): p.read_bytes() for p in sorted((run / "images").rglob("*"))
            if p.is_file()}


def differences(a_dir, b_dir, *, ignore=TIMED) -> list[str]:
    """What differs between runs ``a_dir`` and ``b_dir`` (an empty list: the same results)."""
    a, b = read_results(a_dir), read_results(b_dir)
    out = []
    if list(a.columns) != list(b.columns):
        out.append(f"columns differ: {sorted(set(a.columns) ^ set(b.columns))}")
    if len(a) != len(b):
        return out + [f"{len(a)} rows against {len(b)}"]
    for c in a.columns:
        if c in ignore or c not in b.columns:
            continue
        for i, (x, y) in enumerate(zip(a[c].tolist(), b[c].tolist())):
            if _text([x]) != _text([y]):
                out.append(f"row {i} ({a['method'].iloc[i]}, {a['scene'].iloc[i]}): {c}: {x!r} != {y!r}")
    fa, fb = image_files(a_dir), image_files(b_dir)
    out += [f"image only in one run: {k}" for k in sorted(set(fa) ^ set(fb))]
    out += [f"image differs: {k}" for k in sorted(set(fa) & set(fb)) if fa[k] != fb[k]]
    return out


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m ldbench.harness.executors.check RUN_A RUN_B", file=sys.stderr)
        return 2
    diffs = differences(*args)
    for d in diffs:
        print(d)
    print(f"{len(diffs)} differences" if diffs else "same rows, same metrics, same images")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
