#!/usr/bin/env bash
# The tiles' sort of the lists they own (structure.splat_sort, docs/fast_builds.md) on the GPU: the build tests,
# the copy bandwidth, the Figure 8 build alone and the Figure 8 and 10 frames with and without it, and the
# Figure 8 frame with the held fragments' nodes allocated at once instead of at the end (a patched copy).
#
# Usage, from the project root with its Python environment set up:
#     OUT=/some/dir bash scripts/gpu/tile-sort.sh [--dry]
# Output: $OUT/tile-sort.tgz (CSVs, Markdown tables, logs) and the tables on stdout.
set -u
PY="${PYTHON:-python3}"
case $PY in */*) PY="$(cd "$(dirname "$PY")" && pwd)/$(basename "$PY")" ;; esac   # usable from the copy below
DRY=("$@")
W="$(mktemp -d "${TMPDIR:-/tmp}/tile-sort.XXXXXX")"
export LDBENCH_CACHE=${LDBENCH_CACHE:-/tmp/ldb-cache} LDBENCH_SCENES=${LDBENCH_SCENES:-/tmp/ldb-scenes}
step() {  # step SECONDS NAME CMD...
    local t=$1 name=$2; shift 2
    echo "==== $name (limit $t s)" | tee -a "$W/log.txt"
    timeout --kill-after=10 "$t" "$@" >> "$W/log.txt" 2>&1
    echo "     rc=$?" | tee -a "$W/log.txt"
}
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv >> "$W/log.txt" 2>&1
step 150 tests "$PY" -m pytest -q -p no:cacheprovider tests/test_builds.py
tail -3 "$W/log.txt"
step 60 bandwidth "$PY" scripts/gpu/fast_builds_bench.py "$W/main" bandwidth "${DRY[@]}"
step 120 fig8-build "$PY" scripts/gpu/fast_builds_bench.py "$W/main" fig8 "${DRY[@]}" --variants \
    splat/linked-yang-queue-batch16-aggregate,splat/linked-yang-queue-batch16-aggregate-tilesort
step 200 fig8-frame "$PY" scripts/gpu/fast_defaults.py "$W/main" "${DRY[@]}" --only fig8 \
    --labels "default, no splat_sort;default, splat_sort"
# the held fragments' nodes allocated at once, as with a payload
rm -rf "$W/tree"; mkdir -p "$W/tree"
for d in core harness methods references reports scripts suites pyproject.toml; do cp -r "$d" "$W/tree/"; done
"$PY" - "$W/tree/methods/glsl/splat_tiles.glsl" <<'PYEOF'
import sys
p = sys.argv[1]
s = open(p).read()
a = "#if defined(SP_SORTING) && LS_PAYLOAD == 0\n            if (held"
assert s.count(a) == 1
s = s.replace(a, "#if 0\n            if (held").replace("#if defined(SP_SORTING) && LS_PAYLOAD > 0\n", "#if defined(SP_SORTING)\n")
open(p, "w").write(s)
PYEOF
mkdir -p "$W/early"; cp "$W/main/bandwidth.csv" "$W/early/" 2>/dev/null
(cd "$W/tree" && LDBENCH_LINKS="$W/links" . scripts/gpu/env.sh &&
 step 150 fig8-frame-early-alloc "$PY" scripts/gpu/fast_defaults.py "$W/early" "${DRY[@]}" --only fig8 \
     --labels "default, splat_sort")
mkdir -p "$W/fig10"; cp "$W/main/bandwidth.csv" "$W/fig10/" 2>/dev/null
step 200 fig10-frame "$PY" scripts/gpu/fast_defaults.py "$W/fig10" "${DRY[@]}" --only fig10 \
    --labels "default, no splat_sort;default, splat_sort"
grep -h "variant=" "$W/log.txt" | cut -c1-400
for d in main early fig10; do grep "^| fig" "$W/$d/fast-defaults.md" 2>/dev/null; done
mkdir -p "${OUT:-/tmp/ldbench-gpu}"
tar czf "${OUT:-/tmp/ldbench-gpu}/tile-sort.tgz" --exclude='*.exr' --exclude='*.npz' -C "$W" .
