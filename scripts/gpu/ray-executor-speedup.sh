#!/usr/bin/env bash
# GPU measurement of the Ray executor over all GPUs of one machine against a serial run of the
# same suite (default suites/aalund2015-ao.toml at the paper's scale: 90 jobs, 18 references).
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/ray-executor-speedup.sh [STEP ...]
# STEPs (default: serial ray summary):
#     serial   ldbench run SUITE                 (runs/ray-executor-speedup/serial, its own reference cache)
#     ray      ldbench run SUITE --executor ray  over all GPUs (runs/ray-executor-speedup/ray-N)
#     ray:K    the same on the first K GPUs only (CUDA_VISIBLE_DEVICES=0..K-1: the speed-up curve)
#     summary  speed-up against the GPU count, equality of every row's metrics and images with the serial
#              run (ldbench.harness.executors.check), per row the EGL device, CUDA device and PCI bus id, and
#              each run's own log lines (references the driver rendered while the workers started, calls
#              and busy time per worker; where the serial process's and each worker's time went, by phase)
#              -> "$OUT/ray-executor-speedup/": summary.md, timings.csv, rows.csv, diffs.txt, gpu.txt, log.txt
# The runs stay in runs/ray-executor-speedup/ (ignored by git), so steps can be split over several
# commands on one machine, e.g. `... ray-executor-speedup.sh serial` then `... ray-executor-speedup.sh ray summary`.
# Each run renders its own references (a fresh cache per run): the Ray run gets no head start from the serial
# one, and equal images prove that references too are the same on every GPU.
#
# Environment: LDBENCH_GPU_SUITE (suite file), LDBENCH_GPU_RUN_ARGS (extra `ldbench run` arguments; if the
# paper scale does not fit, "--size 400x400 --spp 256"), LDBENCH_GPU_RUN_TIMEOUT (seconds per run, default
# 270: two runs and the summary fit in 10 minutes), PYTHON (default python3).
# LDBENCH_GPU_DRY=1: a CPU dry run (aalund2015-ao-ci.toml at 32x32, a local Ray cluster of CPU workers) to test
# this script on llvmpipe.
#
# Ray on a GPU machine without network access and without Ray (Python 3.12): slim wheels, Ray's 31 MiB
# Java jar removed (the Python API does not use it):
#     bash scripts/gpu/ray-executor-speedup.sh bundle    # with network: .raywhl/ = ray 2.60.0 cp312 (jar
#                                                        # removed) + jsonschema, jsonschema-specifications,
#                                                        # referencing, rpds-py: 43.9 MiB
#     copy the checkout with .raywhl/ to the GPU machine, there:
#     bash scripts/gpu/ray-executor-speedup.sh install   # -> .raysite/ (kept for later runs: git ignores it)
#     OUT=$OUT bash scripts/gpu/ray-executor-speedup.sh
# (click, filelock, msgpack, protobuf, pyyaml, requests, packaging, attrs are in the GPU image already.)
# (`bundle` and `install` add `/.raywhl/` and `/.raysite/` to .git/info/exclude.)
set -u
cd "$(dirname "$0")/../.."
PY="${PYTHON:-python3}"
O="${OUT:-/tmp/ldbench-gpu}/ray-executor-speedup"
W="runs/ray-executor-speedup"
DRY="${LDBENCH_GPU_DRY:-0}"
SUITE="${LDBENCH_GPU_SUITE:-suites/aalund2015-ao.toml}"
ARGS="${LDBENCH_GPU_RUN_ARGS:-}"
T="${LDBENCH_GPU_RUN_TIMEOUT:-270}"
RAY_VERSION=2.60.0
if [ "$DRY" = 1 ]; then
    SUITE="${LDBENCH_GPU_SUITE:-suites/aalund2015-ao-ci.toml}"
    ARGS="${LDBENCH_GPU_RUN_ARGS:---size 32x32 --spp 16}"
fi
[ -d .raysite ] && export PYTHONPATH="$PWD/.raysite${PYTHONPATH:+:$PYTHONPATH}"
mkdir -p "$O" "$W"
touch "$O/log.txt"
log() { echo "$*" | tee -a "$O/log.txt"; }

exclude() {  # keep the wheels and their install out of git (and so out of what travels uncarried)
    local ex
    ex="$(git rev-parse --git-path info/exclude 2>/dev/null)" || return 0
    for p in /.raywhl/ /.raysite/; do grep -qxF "$p" "$ex" 2>/dev/null || echo "$p" >> "$ex"; done
}

bundle() {  # here, with network access to the package index
    exclude
    rm -rf .raywhl && mkdir -p .raywhl
    "$PY" -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
        --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
        -d .raywhl "ray==$RAY_VERSION" "jsonschema==4.26.0" "jsonschema-specifications==2025.9.1" \
        "referencing==0.37.0" "rpds-py==2026.9.1" || exit 1
    zip -q -d .raywhl/ray-*.whl 'ray/jars/*' 'ray/dashboard/client/build/static/js/*.map' || exit 1
    ls -l .raywhl | awk 'NR > 1 {s += $5; print $5, $9} END {printf "%.1f MiB\n", s / 1048576}'
}

install() {  # on the GPU machine, from the copied .raywhl/
    exclude
    "$PY" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target .raysite \
        .raywhl/*.whl && PYTHONPATH="$PWD/.raysite${PYTHONPATH:+:$PYTHONPATH}" "$PY" -c \
        "import ray; print('ray', ray.__version__, 'in .raysite')"
}

ngpus() {
    if [ "$DRY" = 1 ]; then nproc; return; fi
    nvidia-smi -L 2>/dev/null | grep -c '^GPU '
}

run() {  # run NAME [K]: one `ldbench run` into $W/NAME, wall clock into $W/NAME.wall
    local name=$1 k=${2:-} ex=() env=()
    rm -rf "$W/$name" "$W/cache-$name"
    if [ -n "$k" ]; then
        ex=(--executor ray)
        if [ "$DRY" != 1 ] && [ "$k" -lt "$(ngpus)" ]; then
            env=(CUDA_VISIBLE_DEVICES="$(seq -s, 0 $((k - 1)))")
        fi
        "$PY" -c "import ray" 2>/dev/null || { log "$name: ray is not importable (see 'install' above)"; return; }
    fi
    log "== $name: ${env[*]:-} ldbench run $SUITE $ARGS ${ex[*]:-}"
    local t0 t1 rc
    t0=$(date +%s.%N)
    # shellcheck disable=SC2086
    env LDBENCH_CACHE="$PWD/$W/cache-$name" "${env[@]}" timeout "$T" "$PY" -m ldbench.harness.cli run "$SUITE" $ARGS \
        "${ex[@]}" --out "$W/$name" --no-progress --no-report > "$W/$name.log" 2>&1
    rc=$?
    t1=$(date +%s.%N)
    echo "$t0 $t1 $rc ${k:-0}" > "$W/$name.wall"
    log "   $name: rc=$rc (0: all ok, 1: some row not ok, 124: timed out) in $(awk "BEGIN {printf \"%.1f\", $t1 - $t0}") s"
    tail -n 3 "$W/$name.log" >> "$O/log.txt"
    grep "^ldbench: \(ray\|local\):" "$W/$name.log" >> "$O/log.txt"  # where each process's time went
}

summary() {
    nvidia-smi --query-gpu=index,name,pci.bus_id,uuid,driver_version --format=csv > "$O/gpu.txt" 2>&1
    "$PY" - "$W" "$O" <<'EOF'
import json, re, sys
from pathlib import Path

import pandas as pd

from ldbench.core.egl import nvidia_gpus
from ldbench.harness.executors.check import differences
from ldbench.harness.records import read_results

gpus = nvidia_gpus()

work, out = Path(sys.argv[1]), Path(sys.argv[2])
runs = {}
for f in sorted(work.glob("*.wall")):
    t0, t1, rc, k = f.read_text().split()
    runs[f.stem] = {"seconds": float(t1) - float(t0), "rc": int(rc), "gpus": int(k), "done": (work / f.stem / "results.parquet").is_file()}
lines = ["# The Ray executor against a serial run", ""]
serial = runs.get("serial")
tim = []
for name, r in runs.items():
    speed = serial["seconds"] / r["seconds"] if serial and r["done"] and serial["done"] else float("nan")
    tim.append({"run": name, "gpus": r["gpus"] or 1, "executor": "local" if name == "serial" else "ray",
                "wall_s": round(r["seconds"], 2), "rc": r["rc"], "complete": r["done"],
                "speedup": round(speed, 3), "efficiency": round(speed / (r["gpus"] or 1), 3)})
tim = pd.DataFrame(tim)
tim.to_csv(out / "timings.csv", index=False)
md = ["| " + " | ".join(tim.columns) + " |", "|" + "---|" * len(tim.columns)]
md += ["| " + " | ".join(str(v) for v in r) + " |" for r in tim.itertuples(index=False)]
lines += ["## Wall clock (whole `ldbench run`, references included)", "", *md, "", "## Results and devices", ""]
rows, diffs = [], []
log = work / "serial.log"  # the serial process's split, to hold against each worker's
for ln in (log.read_text(errors="replace").splitlines() if log.is_file() else []):
    if ln.startswith("ldbench: local: "):
        lines.append(f"- **serial**: `{ln[len('ldbench: '):]}`")
for name, r in runs.items():
    if name == "serial" or not r["done"]:
        continue
    df = read_results(work / name)
    if serial and serial["done"]:
        d = differences(work / "serial", work / name)
        diffs += [f"{name}: {x}" for x in d]
        lines.append(f"- **{name}**: {len(df)} rows; against the serial run: " +
                     ("every column except times and devices equal, every image byte for byte equal"
                      if not d else f"{len(d)} differences (diffs.txt)"))
    m = [x if isinstance(x, dict) else {} for x in df["machine"]]
    sel = [x.get("egl_selection") for x in m]
    # the GPU Ray gave the task (nvidia-smi, by CUDA_VISIBLE_DEVICES) against the EGL device's own PCI id
    given = [next((g["pci_bus_id"] for g in gpus if c in (g["index"], g["uuid"])), None) for c in df["cuda_device"]]
    per = df.assign(run=name, host=[x.get("hostname") for x in m], egl_selection=sel,
                    pci_from=[x.get("pci_from") for x in m], given_pci=given)[
        ["run", "scene", "method", "effect_params", "params", "status", "psnr", "ssim", "egl_device",
         "cuda_device", "pci_bus_id", "pci_from", "given_pci", "egl_selection", "host"]]
    own = per[per["pci_from"].isin(["uuid", "drm"]) & per["given_pci"].notna()]
    lines.append(f"  EGL device = the worker's GPU (PCI id from the EGL device itself vs nvidia-smi's for "
                 f"CUDA_VISIBLE_DEVICES): {int((own['pci_bus_id'] == own['given_pci']).sum())} of {len(own)} rows; "
                 f"{len(per) - len(own)} rows without an EGL-side PCI id")
    rows.append(per)
    ok = df["status"].eq("ok") | df["status"].str.startswith("degraded")
    lines.append(f"  {df['pci_bus_id'].nunique()} distinct PCI bus ids over {ok.sum()} rows that ran "
                 f"({dict(df['pci_bus_id'].value_counts())}); EGL devices {sorted(df['egl_device'].dropna().unique().tolist())}; "
                 f"selection {sorted(set(s for s in sel if s))}")
    log = work / f"{name}.log"  # the executor's own lines: references in the driver, each worker's calls
    for ln in (log.read_text(errors="replace").splitlines() if log.is_file() else []):
        if ln.startswith("ldbench: ray: "):
            lines.append(f"  `{ln[len('ldbench: ray: '):]}`")
    cons = per.dropna(subset=["cuda_device"]).groupby("cuda_device")["pci_bus_id"].nunique()
    if len(cons) and (cons > 1).any():
        lines.append(f"  WARNING: one CUDA device with several PCI bus ids: {dict(cons)}")
if rows:
    pd.concat(rows).to_csv(out / "rows.csv", index=False)
# the measured frames per method, summed over its jobs' medians: GPU time (timer queries) and wall clock. Equal
# GPU times and a larger wall clock in a Ray run: the worker's CPU side, not the GPU, is slower
frames = []
for name, r in runs.items():
    if r["done"]:
        df = read_results(work / name)
        frames.append(df.groupby("method")[["total_ms", "wall_ms"]].sum().round(1).assign(run=name).reset_index())
# the split lines (ldbench/harness/phases.py) as one table: per phase, seconds and ms per call of the serial process
# and of all workers of each Ray run (its driver's references apart)
split = {}
for name in runs:
    log = work / f"{name}.log"
    for ln in (log.read_text(errors="replace").splitlines() if log.is_file() else []):
        m = re.match(r"ldbench: (local: .*? s: |ray: worker \d+ split: |ray: driver split: )(.*)", ln)
        if not m:
            continue
        col = name + (" driver" if "driver" in m.group(1) else "")
        for k, n, sec in re.findall(r"([a-z][a-z ]*?) (\d+)× ([0-9.]+) s", m.group(2).split(";")[0]):
            c, t = split.setdefault(k, {}).get(col, (0, 0.0))
            split[k][col] = (c + int(n), t + float(sec))
        idle = re.search(r"idle between calls ([0-9.]+) s, ([0-9.]+) s before its first", ln)
        for k, sec in zip(("(idle between calls)", "(idle before the first call)"), idle.groups() if idle else ()):
            c, t = split.setdefault(k, {}).get(col, (0, 0.0))
            split[k][col] = (c + 1, t + float(sec))
if split:
    cols = sorted({c for v in split.values() for c in v})
    lines += ["", "## Where the time went, by phase (seconds; ms per call)", "",
              "| phase | " + " | ".join(cols) + " |", "|---|" + "---|" * len(cols)]
    lines += [f"| {k} | " + " | ".join(f"{v[c][1]:.1f} ({1e3 * v[c][1] / max(v[c][0], 1):.0f})" if c in v else ""
                                       for c in cols) + " |" for k, v in split.items()]
if frames:
    ft = pd.concat(frames).pivot(index="method", columns="run", values=["total_ms", "wall_ms"])
    ft.columns = [f"{a} {b}" for a, b in ft.columns]
    lines += ["", "## Frame times per method (sum over its jobs of the median frame, ms)", "",
              "| method | " + " | ".join(ft.columns) + " |", "|---|" + "---|" * len(ft.columns)]
    lines += [f"| {m} | " + " | ".join(str(v) for v in row) + " |" for m, row in zip(ft.index, ft.values.tolist())]
(out / "diffs.txt").write_text("\n".join(diffs) + ("\n" if diffs else "no differences\n"))
(out / "summary.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
EOF
}

steps=("$@")
[ ${#steps[@]} -eq 0 ] && steps=(serial ray summary)
for s in "${steps[@]}"; do
    case "$s" in
        bundle) bundle ;;
        install) install ;;
        serial) run serial ;;
        ray) n=$(ngpus); run "ray-$n" "$n" ;;
        ray:*) run "ray-${s#ray:}" "${s#ray:}" ;;
        summary) summary ;;
        *) echo "unknown step $s (bundle install serial ray ray:K summary)" >&2; exit 2 ;;
    esac
done
