#!/usr/bin/env bash
# Re-measure, after the staging read-back (ldbench/core/gpu.py Gpu.read), the H200 figures that earlier runs took
# while NVIDIA's driver had moved CPU-read buffers to host memory (docs/fast_builds.md, "Read-backs"):
# Sibenik LDM AO at the Figure 8 settings (pre-sorted insert; 1013 ms before), the hairball stress build
# (sorted insert; 274 ms before) and yang2010's Table 1 teapot (ll-oit 43.7 ms before).
#     OUT=/some/dir bash scripts/gpu/readback-regression.sh MIRROR      # MIRROR: a scene mirror holding sibenik/
# -> "$OUT/readback-regression/": summary.md and each run's results.csv. Every step under `timeout`, continuing past failures.
set -u
O="${OUT:-/tmp/ldbench-gpu}/readback-regression"
mkdir -p "$O"
PY="${PYTHON:-python3}"
LD="$PY -m ldbench.harness.cli"
export LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
step() {
    local t=$1 name=$2; shift 2
    local t0=$SECONDS
    timeout "$t" "$@" > "$O/$name.log" 2>&1
    echo "$name: rc=$? in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
}
[ -n "${1:-}" ] && step 20 fetch $LD scenes fetch sibenik --from "$1"
step 60 sibenik $LD run --scene sibenik --method ldm --effect ao --falloff quadratic --d-max 13.6 --size 800x800 \
    --spp 256 --set ldm.directions=512 --set ldm.resolution=200 --warmup 2 --frames 5 --out /tmp/rb-sibenik \
    --no-progress --no-report
step 40 hairball $LD run --scene hairball --method ldm --effect ao --size 256x256 --spp 64 --warmup 1 --frames 3 \
    --set ldm.layout=linked --set ldm.directions=256 --set ldm.resolution=128 --out /tmp/rb-hairball --no-progress --no-report
step 40 teapot $LD run --scene teapot --method ll-oit --method depth-peeling --method dual-depth-peeling --effect oit \
    --size 512x512 --warmup 3 --frames 10 --out /tmp/rb-teapot --no-progress --no-report
for r in sibenik hairball teapot; do cp "/tmp/rb-$r/results.csv" "$O/$r-results.csv" 2>/dev/null; done
"$PY" - "$O" <<'PY' | tee "$O/summary.md"
import sys
from pathlib import Path
import pandas as pd
o = Path(sys.argv[1])
for f in sorted(o.glob("*-results.csv")):
    d = pd.read_csv(f)
    print(f"## {f.stem}\n")
    cols = [c for c in ("scene", "method", "params", "total_ms", "stage_ms", "psnr", "status", "gpu_name") if c in d]
    print(d[cols].to_string(index=False), "\n")
PY
