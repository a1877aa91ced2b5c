#!/usr/bin/env bash
# GPU measurements of the fast layered-structure builds (docs/fast_builds.md): aalund2015's Figure 8
# configuration (512 LDMs of 200², atrium 260k, 800², quadratic d_max 10.32 m) with every build variant —
# frame time, memory and PSNR (suites/fast-builds.toml) — the builds alone, against triangles (65k … 4M)
# and against maps (32 … 1024), the fraction of the copy-bandwidth bound they reach, the one-pass raster's
# coverage against the raster, the splat's tuning, and tests/test_builds.py on this GPU (the splat's
# fragments identical to this GPU's hardware raster: its fill rule).
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/fast-builds.sh
# Outputs under "$OUT/fast-builds/": summary.md (the summary, also printed) and fast-builds.tar.gz (CSVs, the two
# figures, the Figure 8 results.csv, logs; < 1 MB). Every step runs under `timeout` (the limits add up to
# 7 min) and a failing step does not stop the script; the bench parts write their rows as they go.
# LDBENCH_GPU_DRY=1: a CPU-sized dry run (tiny scenes and maps, 32² frame) to test the script on llvmpipe.
set -u
O="${OUT:-/tmp/ldbench-gpu}/fast-builds"
mkdir -p "$O"
# LDBENCH_GPU_WORK: keep the working folder there (not removed), so a caller's time limit loses nothing
W="${LDBENCH_GPU_WORK:-$(mktemp -d "${TMPDIR:-/tmp}/fast-builds.XXXXXX")}"
R="$W/fast-builds"
mkdir -p "$R"
: > "$R/log.txt"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
PY="${PYTHON:-python3}"
LD="$PY -m ldbench.harness.cli"
DRY="${LDBENCH_GPU_DRY:-0}"
K=1
B=""
SUITE=suites/fast-builds.toml
RUNARGS=()
if [ "$DRY" = 1 ]; then
    K=4
    B="--dry"
    sed -e 's/triangles = 260000/triangles = 4000/' -e 's/^directions = 512/directions = 8/' \
        -e 's/^resolution = 200/resolution = 32/' suites/fast-builds.toml > "$W/fast-builds.toml"
    SUITE="$W/fast-builds.toml"
    RUNARGS=(--size 32x32 --spp 4 --warmup 0 --frames 1)
fi
step() {  # step SECONDS NAME CMD...: run with a time limit (× K), log, continue on failure
    local t=$(($1 * K)) name=$2; shift 2
    echo "== $name: $*" >> "$R/log.txt"
    local t0=$SECONDS
    timeout "$t" "$@" > "$R/$name.log" 2>&1
    local rc=$?
    echo "   $name: rc=$rc in $((SECONDS - t0)) s (limit $t s)" | tee -a "$R/log.txt"
}

nvidia-smi --query-gpu=name,driver_version,clocks.max.sm,memory.total --format=csv > "$R/gpu.txt" 2>&1
step 10 probe $PY -c "from ldbench.core.gpu import Gpu; from ldbench.methods.structures.splat import fill_rule
g = Gpu(); print(g.info, g.device); print('fill rule', fill_rule(g))"
# the splat's fragments against this GPU's hardware raster (edge cases: ties on texel centres, snapping)
step 45 tests $PY -m pytest -q -p no:cacheprovider tests/test_builds.py
B14="scripts/gpu/fast_builds_bench.py"
step 10 bandwidth $PY "$B14" "$R" bandwidth $B
# the Figure 8 frame with every variant (ldbench's runner: reference, PSNR, memory, invariants)
step 150 fig8-frame $LD run "$SUITE" ${RUNARGS[@]+"${RUNARGS[@]}"} --out "$W/fig8" --no-progress --no-report
cp "$W/fig8/results.csv" "$R/fig8-results.csv" 2>/dev/null
step 40 fig8-builds $PY "$B14" "$R" fig8 $B
step 20 coverage $PY "$B14" "$R" coverage $B
step 45 tune $PY "$B14" "$R" tune $B
step 60 maps $PY "$B14" "$R" maps $B
step 120 triangles $PY "$B14" "$R" triangles $B
step 15 figures $PY scripts/gpu/fast_builds_report.py "$R" "$W/fig8"

cp "$R/summary.md" "$O/summary.md" 2>/dev/null
tar -czf "$O/fast-builds.tar.gz" -C "$W" fast-builds
echo
echo "---- GPU and its fill rule ----"
cat "$R/probe.log" 2>/dev/null
echo "---- tests/test_builds.py on this GPU ----"
tail -3 "$R/tests.log" 2>/dev/null
echo "---- summary ----"
cat "$R/summary.md" 2>/dev/null || echo "(no summary: see the logs in $O/fast-builds.tar.gz)"
[ -n "${LDBENCH_GPU_WORK:-}" ] || rm -rf "$W"
echo "outputs: $O ($(du -sh "$O" | cut -f1))"
