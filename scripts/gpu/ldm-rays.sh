#!/usr/bin/env bash
# GPU measurements of the rays effect through layered depth maps (linked vs linear layouts, the lock-free insert
# under contention, Figure 8 on real scenes), on an NVIDIA GPU with the project's Python environment set up.
# Usage: bash scripts/gpu/ldm-rays.sh [SCENE_MIRROR]     (outputs under $OUT/ldm-rays, small files only)
set -u
O="${OUT:-/tmp/ldbench-gpu}/ldm-rays"
mkdir -p "$O"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
LD="python3 -m ldbench.harness.cli"
step() {  # step SECONDS NAME CMD...: run with a time limit, log, continue on failure
    local t=$1 name=$2; shift 2
    echo "== $name: $*" | tee -a "$O/log.txt"
    local t0=$SECONDS
    timeout "$t" "$@" > "$O/$name.log" 2>&1
    echo "   rc=$? in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
}
keep() {  # keep RUN_DIR NAME: the small files of a run directory
    local d=$1 n=$2
    [ -d "$d" ] || return 0
    cp "$d/results.csv" "$O/$n-results.csv" 2>/dev/null
    cp "$d/summary.md" "$O/$n-summary.md" 2>/dev/null
    cp "$d/reproduce.md" "$O/$n-reproduce.md" 2>/dev/null
    for f in "$d"/figures/rays-*.png "$d"/figures/stages-*.png; do [ -f "$f" ] && cp "$f" "$O/$n-$(basename "$f")"; done
}
nvidia-smi --query-gpu=name,driver_version,clocks.sm,memory.total --format=csv > "$O/gpu.txt" 2>&1
step 60 probe python3 -c "from ldbench.core.gpu import Gpu; g = Gpu(); print(g.info, g.device, g.available_gpu_memory()); g.check_image_size(16384, 16384); print('16384^2 allowed')"
# 1. The GLSL of the layered structures, the lock-free insert under real contention, LDM AO and rays, HBAO
step 120 pytest python3 -m pytest -q -p no:cacheprovider tests/test_layered.py tests/test_linked_list.py \
    tests/test_ldm.py tests/test_rays.py tests/test_hbao.py
# 2. Rays: atrium 260k at 800², 8 diffuse rays per pixel, 512 LDMs of 200², linked vs linear; cornell kinds
step 150 rays $LD run suites/rays-ldm.toml --out /tmp/g-rays --no-progress
keep /tmp/g-rays rays
# 3. The lock-free insert on the GPU at high depth complexity: invariants checked on every row (degraded)
step 60 stress $LD run --scene hairball --method ldm --effect ao --size 256x256 --spp 64 --warmup 1 --frames 3 \
    --set ldm.layout=linked --set ldm.directions=256 --set ldm.resolution=128 --out /tmp/g-stress --no-progress --no-report
keep /tmp/g-stress stress-linked
step 60 stress-linear $LD run --scene hairball --method ldm --effect ao --size 256x256 --spp 64 --warmup 1 --frames 3 \
    --set ldm.layout=linear --set ldm.directions=256 --set ldm.resolution=128 --out /tmp/g-stress2 --no-progress --no-report
keep /tmp/g-stress2 stress-linear
# 4. Figure 8 on the real scenes (needs SCENE_MIRROR, a folder holding sponza/ and sibenik/)
if [ -n "${1:-}" ]; then
    step 60 fetch $LD scenes fetch sponza sibenik --from "$1"
    step 100 fig8-real $LD reproduce aalund2015-fig8-real --size 400x400 --out /tmp/g-f8r --no-progress --no-report
    keep /tmp/g-f8r fig8-real
fi
ls -la "$O" >> "$O/log.txt"
# everything in one archive (one file to copy back from the GPU machine)
tar czf "$O/../ldm-rays-runs.tgz" -C /tmp --exclude='*.exr' --exclude=images g-rays g-stress g-stress2 g-f8r 2>/dev/null
