#!/usr/bin/env bash
# GPU measurements of today's baselines beside the papers' methods: GTAO on the aalund2015 AO sweep and the
# real-scene Figure 8 runs (with its time at 800² and 1920×1080), weighted blended OIT and multi-layer alpha
# blending on the yang2010 Table 1 scenes and the hairball's depth-complexity sweep.
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/modern-baselines.sh ao|oit SCENE_MIRROR
# ao: suites/aalund2015-ao.toml, suites/aalund2015-fig8-real.toml (needs sponza/ and sibenik/ in the mirror)
#     and GTAO/HBAO timing runs; oit: suites/oit-baselines.toml (needs stanford_dragon/).
# Outputs under "$OUT/modern-baselines-PART/": each run's results.csv/parquet, summary.md, its figures
# and the image grids of a few jobs (the rest stay on the GPU host), logs; packed at the end into
# "$OUT/modern-baselines-PART.tgz.part-*" (15 MB pieces: `cat` them and untar). Every step runs under `timeout`.
set -u
part=$1 mirror=$2
O="${OUT:-/tmp/ldbench-gpu}/modern-baselines-$part"
mkdir -p "$O"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
PY="${PYTHON:-python3}"
LD="$PY -m ldbench.harness.cli"
W="$(mktemp -d "${TMPDIR:-/tmp}/modern-baselines.XXXXXX")"
step() {  # step SECONDS NAME CMD...: run with a time limit, log, continue on failure
    local t=$1 name=$2; shift 2
    echo "== $name: $*" >> "$O/log.txt"
    local t0=$SECONDS
    timeout "$t" "$@" > "$O/$name.log" 2>&1
    echo "   $name: rc=$? in $((SECONDS - t0)) s" | tee -a "$O/log.txt"
}
keep() {  # keep RUN [GRID_GLOB]: the run's tables and figures (and the grids matching GRID_GLOB) into $O/RUN
    mkdir -p "$O/$1/figures/grids"
    cp "$W/$1"/results.* "$W/$1"/summary.md "$W/$1"/*.md "$O/$1/" 2>/dev/null
    cp "$W/$1"/figures/*.png "$W/$1"/figures/*.pdf "$O/$1/figures/" 2>/dev/null
    [ -n "${2:-}" ] && cp -r "$W/$1"/figures/grids/$2 "$O/$1/figures/grids/" 2>/dev/null
    return 0
}
nvidia-smi --query-gpu=name,driver_version --format=csv > "$O/gpu.txt" 2>&1
case $part in
ao)
    step 60 fetch $LD scenes fetch sponza sibenik --from "$mirror"
    step 300 ao-sweep $LD run suites/aalund2015-ao.toml --out "$W/ao-sweep" --no-progress
    keep ao-sweep 'atrium-ao-quadratic-d1.5-*'
    step 150 fig8-real $LD reproduce aalund2015-fig8-real --out "$W/fig8-real" --no-progress
    keep fig8-real 'sponza-ao-quadratic-d11*'
    for size in 800x800 1920x1080; do
        for m in gtao hbao; do
            step 60 "time-$m-$size" $LD run --scene atrium --scene-set triangles=260000 --method $m --effect ao \
                --d-max 1.5 --falloff quadratic --size $size --spp 16 --warmup 5 --frames 20 \
                --out "$W/time-$m-$size" --no-progress
            keep "time-$m-$size"
        done
    done ;;
oit)
    step 60 fetch $LD scenes fetch dragon --from "$mirror"
    step 420 oit-baselines $LD run suites/oit-baselines.toml --out "$W/oit-baselines" --no-progress
    keep oit-baselines 'transparent_dragon-*' ;;
*) echo "part: ao | oit" >&2; exit 2 ;;
esac
tar czf "$W/pack.tgz" -C "$(dirname "$O")" "$(basename "$O")" && split -b 15m "$W/pack.tgz" "$O.tgz.part-" && rm -rf "$O"
