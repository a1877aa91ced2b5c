#!/usr/bin/env bash
# Where the default Figure 8 build's time goes (docs/results/fast-defaults-h200.md): the build of
# scripts/gpu/fast_builds_bench.py (fig8 part: 512 maps of 200² on atrium 260k) timed in a throw-away copy
# of the checkout whose store is cut short: (1) as is; (2) raster only, no store; (3) the node counter's
# atomic only, no head exchange and no node write. The checkout itself is not touched.
#
# Usage, from the project root with its Python environment set up:
#     bash scripts/gpu/fig8-build-split.sh [--dry]
set -u
PY="${PYTHON:-python3}"
src=$PWD
W="$(mktemp -d "${TMPDIR:-/tmp}/fig8-split.XXXXXX")"
trap 'rm -rf "$W"' EXIT
V=splat/linked-yang,splat/linear-sort
run() {  # run LABEL: the bench in the copy
    echo "== $1"
    (cd "$W/tree" && LDBENCH_LINKS="$W/links" . scripts/gpu/env.sh &&
     timeout 200 "$PY" scripts/gpu/fast_builds_bench.py "$W/out-$1" fig8 --variants "$V" "$@" 2>&1 |
     grep -o "variant=[^ ]* build_ms=[^ ]*\|stages=[^ ]*" | paste - -)
}
copy() { rm -rf "$W/tree"; mkdir -p "$W/tree"; (cd "$src" && git ls-files -z | xargs -0 cp -P --parents -t "$W/tree"); }
patch() {  # patch FILE OLD NEW (exactly one occurrence)
    "$PY" - "$W/tree/$1" "$2" "$3" <<'PYEOF'
import sys
p, a, b = sys.argv[1:4]
s = open(p).read()
assert s.count(a) == 1, (p, a)
open(p, "w").write(s.replace(a, b))
PYEOF
}
copy; run as-is "${@:1}"
copy
patch methods/glsl/linked_list.glsl $'uint ll_insert_unsorted(uint list, float z, uint capacity) {\n' \
    $'uint ll_insert_unsorted(uint list, float z, uint capacity) {\n    if (z != 1.0e30) return LL_EOL;\n'
patch methods/glsl/layered_store.glsl $'    uint slot = ls_reserve_pair();\n' $'    if (depth != 1.0e30) return;\n    uint slot = ls_reserve_pair();\n'
run raster-only "${@:1}"
copy
patch methods/glsl/linked_list.glsl $'    uint old = atomicExchange(ll_head[list], n);\n' \
    $'    if (z != 1.0e30) return n;\n    uint old = atomicExchange(ll_head[list], n);\n'
run counter-only "${@:1}"
