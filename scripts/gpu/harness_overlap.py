"""The harness's own cost, side by side: the same suites run one job after the other (``--writers 0``) and with
writer processes scoring and saving while the next jobs render (``--writers N``, ldbench/harness/writers.py).

    python scripts/gpu/harness_overlap.py OUT [--suite SUITE ...] [--writers 0,2,auto] [--repeat R]
        [--report] [--dry] [-- EXTRA RUN ARGUMENTS]

Default suites: ``small`` (39 short AO jobs at 256²: cornell, atrium 20k and hairball 20k; hbao, gtao and a
small ldm; written by this script) and suites/default.toml (``make bench``). On the GPU host, the sweep of
the harness goal: ``OUT --suite suites/aalund2015-ao.toml --writers 0,auto``. ``--dry``: the small suite
at 32², once, writers 0 and 1 (tests the script on llvmpipe in about a minute).

Every run gets the same reference cache (``OUT/cache``), filled by one untimed run of each suite first, so
that the runs differ only in the harness. Runs alternate (for each repeat, every writer count in turn) so
that a machine whose load drifts treats them alike. Each run is ``ldbench run`` in its own process; the
table gives its wall clock, the run's own time split (the ``ldbench: local:`` line: the main thread's phases,
and the writers' own seconds, which overlap them), and whether its rows and images equal those of the
``--writers 0`` run of the same repeat (``ldbench.harness.executors.check``: every column but the times,
every image byte for byte). ``auto`` is ``ldbench run`` without ``--writers`` (its default for the device).

Writes OUT/overlap.md and OUT/overlap.csv (and the runs and their reference cache under OUT) and prints
the table.
"""
from __future__ import annotations

import argparse
import csv
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SMALL_SUITE = """\
# written by scripts/gpu/harness_overlap.py: many short jobs, where the harness's own cost shows
[suite]
name = "harness-overlap-small"
size = "256x256"
spp = 64
warmup = 0
frames = 1

[[run]]
scene = "cornell"
effect = "ao"
d_max = [0.1, 0.25, 0.5, 1.0]
falloff = ["step", "quadratic"]
methods = ["hbao", "gtao", "ldm"]

[run.params.ldm]
directions = 16
resolution = 64

[[run]]
scene = "atrium"
scene_params = { triangles = 20000 }
effect = "ao"
d_max = [1.5, 3.0]
falloff = ["step", "quadratic"]
methods = ["hbao", "gtao", "ldm"]

[run.params.ldm]
directions = 16
resolution = 64

[[run]]
scene = "hairball"
scene_params = { triangles = 20000 }
effect = "ao"
d_max = 0.5
methods = ["hbao", "gtao", "ldm"]

[run.params.ldm]
directions = 16
resolution = 64
"""

#: The time split's phases in the table's columns (the rest is in the CSV).
COLUMNS = ("references", "setup", "frames", "score", "save", "handoff", "wait")


def split_of(line: str) -> dict:
    """``{phase: seconds}`` of a ``ldbench: local: ...`` line; the writers' phases as ``writers <phase>``."""
    main, _, writers = line.partition("; ")
    out: dict = {}
    for part, prefix in ((main, ""), (writers.split(": ", 1)[-1] if writers else "", "writers ")):
        for name, _calls, sec in re.findall(r"([a-z][a-z ]*?) (\d+)× ([0-9.]+) s", part):
            out[prefix + name] = out.get(prefix + name, 0.0) + float(sec)
    m = re.search(r"jobs in ([0-9.]+) s", main)
    out["run"] = float(m.group(1)) if m else float("nan")
    out["references"] = out.get("reference render", 0.0) + out.get("reference cache", 0.0)
    return out


def run_once(suite: Path, writers: str, out: Path, cache: Path, extra: list, report: bool) -> dict:
    """One ``ldbench run``: its wall clock, exit status, time split and log."""
    args = [sys.executable, "-m", "ldbench.harness.cli", "run", str(suite), "--out", str(out), "--no-progress"]
    args += [] if report else ["--no-report"]
    args += [] if writers == "auto" else ["--writers", writers]
    t0 = time.perf_counter()
    p = subprocess.run(args + extra, cwd=ROOT, capture_output=True, text=True,
                       env=dict(os.environ, LDBENCH_CACHE=str(cache)))
    wall = time.perf_counter() - t0
    line = next((ln for ln in p.stderr.splitlines() if ln.startswith("ldbench: local: ")), "")
    return {"wall": wall, "rc": p.returncode, "split": split_of(line), "line": line, "stderr": p.stderr}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder for the runs, the reference cache and the table")
    ap.add_argument("--suite", action="append", help="suite file or 'small' (repeatable; default: small and "
                                                     "suites/default.toml)")
    ap.add_argument("--writers", default="0,2,auto", help="writer counts to compare, 0 first (default 0,2,auto)")
    ap.add_argument("--repeat", type=int, default=2, help="runs of each (suite, writers) (default 2)")
    ap.add_argument("--dry", action="store_true", help="the small suite at 32x32, once, writers 0 and 1")
    ap.add_argument("--report", action="store_true", help="write each run's report too (as `make bench` does)")
    ap.add_argument("extra", nargs="*", help="more `ldbench run` arguments (after --)")
    a, rest = ap.parse_known_args(argv)  # `-- --spp 64`: argparse leaves what follows `--` here
    a.extra = [*a.extra, *[x for x in rest if x != "--"]]
    from ldbench.harness.executors.check import differences

    if a.dry:
        a.suite, a.writers, a.repeat, a.extra = ["small"], "0,1", 1, [*a.extra, "--size", "32x32", "--spp", "4"]
    a.out = a.out.resolve()
    writers = [w.strip() for w in a.writers.split(",") if w.strip()]
    if writers[0] != "0":
        writers.insert(0, "0")  # the serial run every other is checked against
    a.out.mkdir(parents=True, exist_ok=True)
    cache = a.out / "cache"
    suites = []
    for s in a.suite or ["small", "suites/default.toml"]:
        if s == "small":
            p = a.out / "small.toml"
            p.write_text(SMALL_SUITE)
            suites.append(p)
        else:
            suites.append(Path(s).resolve())
    rows = []
    for suite in suites:
        warm = run_once(suite, "auto", a.out / "warm", cache, a.extra, False)  # the references, once, untimed
        print(f"{suite.name}: references ready (untimed run: rc {warm['rc']}, {warm['wall']:.1f} s)", flush=True)
        if warm["rc"] not in (0, 1):
            print(warm["stderr"], file=sys.stderr)
            return 1
        for rep in range(a.repeat):
            for w in writers:
                d = a.out / f"{suite.stem}-w{w}-{rep}"
                r = run_once(suite, w, d, cache, a.extra, a.report)
                same = "(serial)" if w == "0" else (
                    "yes" if not differences(a.out / f"{suite.stem}-w0-{rep}", d) else "NO") if r["rc"] in (0, 1) \
                    else f"rc {r['rc']}"
                row = {"suite": suite.stem, "writers": w, "repeat": rep, "wall_s": round(r["wall"], 2),
                       "run_s": r["split"].get("run"), "same_as_serial": same,
                       **{k: round(v, 2) for k, v in r["split"].items() if k != "run"}}
                rows.append(row)
                print(f"  writers {w:>4} #{rep}: {r['wall']:.1f} s  {r['line'][len('ldbench: '):]}", flush=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(a.out / "overlap.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=keys)
        wr.writeheader()
        wr.writerows(rows)
    head = ["suite", "writers", "#", "wall s", "run s", *COLUMNS, "writers' score", "writers' save", "same rows"]
    md = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["suite"], r["writers"], r["repeat"], r["wall_s"], r["run_s"],
                 *[r.get(k, 0.0) for k in COLUMNS], r.get("writers score", ""), r.get("writers save", ""),
                 r["same_as_serial"]]
        md.append("| " + " | ".join(str(c) for c in cells) + " |")
    text = "\n".join([f"`{' '.join(['python', 'scripts/gpu/harness_overlap.py', *(argv or sys.argv[1:])])}`", "",
                      *md, "", "Seconds. `score`, `save`: on the main thread; `writers' score`, `writers' save`: "
                      "the writer processes' own, summed over them, overlapping the main thread's phases."])
    (a.out / "overlap.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
