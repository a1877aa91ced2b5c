#!/usr/bin/env bash
# GPU measurements of the fast defaults against the paper presets (docs/fast_builds.md, "Defaults"): the
# before/after table of scripts/gpu/fast_defaults.py (Figure 8 and 10 frames, the CDI build, HBAO, the LDI
# build), the copy bandwidth it divides by, and the default build's time against triangles (65k … 4M) and
# against maps (32 … 1024) with scripts/gpu/fast_builds_bench.py.
#
# Also the Figure 8 build alone (the linked default and the linear sort assembly), and the compute G-buffer's
# timing and textures (gbuffer_bench.py).
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/fast-defaults.sh [ROWS]      ROWS: e.g. fig8,cdi (default: all)
# LDBENCH_GPU_SWEEPS: which build sweeps to run (default "triangles maps"; "" for none).
# LDBENCH_GPU_FIG8_VARIANTS: the variants of the Figure 8 build alone (fast_builds_bench.py --variants).
# Output: "$OUT/fast-defaults.tgz" (CSVs, the Markdown table, the runs' results, logs). Each step runs under
# `timeout` and a failing step does not stop the script. LDBENCH_GPU_DRY=1: a CPU-sized dry run.
set -u
W="${LDBENCH_GPU_WORK:-$(mktemp -d "${TMPDIR:-/tmp}/fast-defaults.XXXXXX")}/fast-defaults"
mkdir -p "$W"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
PY="${PYTHON:-python3}"
DRY=()
[ "${LDBENCH_GPU_DRY:-0}" = 1 ] && DRY=(--dry)
ONLY=()
[ $# -ge 1 ] && ONLY=(--only "$1")
step() {  # step SECONDS NAME CMD...
    local t=$1 name=$2; shift 2
    echo "==== $name (limit $t s)" | tee -a "$W/log.txt"
    timeout --kill-after=10 "$t" "$@" >> "$W/log.txt" 2>&1
    echo "     rc=$?" | tee -a "$W/log.txt"
}
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv >> "$W/log.txt" 2>&1
step 60 bandwidth "$PY" scripts/gpu/fast_builds_bench.py "$W" bandwidth "${DRY[@]}"
step 330 before-after "$PY" scripts/gpu/fast_defaults.py "$W" "${DRY[@]}" "${ONLY[@]}"
F8=${LDBENCH_GPU_FIG8_VARIANTS:-splat/linked-yang-queue-batch16-aggregate-tilesort,splat/linked-yang-queue-batch16-aggregate,splat/linear-sort}
step 120 fig8-build "$PY" scripts/gpu/fast_builds_bench.py "$W" fig8 "${DRY[@]}" --variants "$F8"
GB=()
[ "${LDBENCH_GPU_DRY:-0}" = 1 ] && GB=(--dry)
step 90 gbuffer "$PY" scripts/gpu/gbuffer_bench.py "${GB[@]}"
V=splat/linked-yang-queue-batch16-aggregate-tilesort   # the Figure 8 default structure
for sweep in ${LDBENCH_GPU_SWEEPS-triangles maps}; do
    step 150 "$sweep" "$PY" scripts/gpu/fast_builds_bench.py "$W" "$sweep" "${DRY[@]}" --variants "$V"
done
cat "$W/fast-defaults.md" 2>/dev/null
mkdir -p "${OUT:-/tmp/ldbench-gpu}"
tar czf "${OUT:-/tmp/ldbench-gpu}/fast-defaults.tgz" --exclude='*.exr' --exclude='*.npz' -C "$(dirname "$W")" fast-defaults
ls -la "${OUT:-/tmp/ldbench-gpu}"
