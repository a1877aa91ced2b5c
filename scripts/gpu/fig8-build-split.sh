#!/usr/bin/env bash
# Where the default Figure 8 build's time goes (docs/results/fast-defaults-h200.md): the build of
# scripts/gpu/fast_builds_bench.py (fig8 part: 512 maps of 200² on atrium 260k) timed in throw-away copies
# of the checkout with one part cut: (1) as is; (2) without the compute splat's small triangles; (3)
# without the long triangles' tiles; (4) the small triangles testing coverage but storing nothing; (5) the
# small triangles' stores stopped after the node counter's atomic (yang2010's insert, which only they use);
# (6) the tiles testing coverage but storing nothing; (7) without the sort pass. Cut builds store fewer
# fragments or leave lists unsorted: their rows read "degraded", and only their times mean anything. The
# checkout itself is not touched.
#
# Usage, from the project root with its Python environment set up:
#     bash scripts/gpu/fig8-build-split.sh [--dry]
set -u
PY="${PYTHON:-python3}"
src=$PWD
W="$(mktemp -d "${TMPDIR:-/tmp}/fig8-split.XXXXXX")"
trap 'rm -rf "$W"' EXIT
V=splat/linked-yang
ARGS=("$@")
run() {  # run LABEL: the bench in the copy, with this script's arguments
    echo "== $1"
    (cd "$W/tree" && LDBENCH_LINKS="$W/links" . scripts/gpu/env.sh &&
     timeout 200 "$PY" scripts/gpu/fast_builds_bench.py "$W/out-$1" fig8 --variants "$V" ${ARGS[@]+"${ARGS[@]}"} 2>&1 |
     grep -o "variant=[^ ]* build_ms=[^ ]*\|stages=[^ ]*" | paste - -)
}
copy() {  # the package's folders and the scripts, as they are in the working tree
    rm -rf "$W/tree"; mkdir -p "$W/tree"
    for d in core harness methods references reports scripts suites pyproject.toml; do cp -r "$src/$d" "$W/tree/"; done
}
patch() {  # patch FILE OLD NEW (exactly one occurrence)
    "$PY" - "$W/tree/$1" "$2" "$3" <<'PYEOF'
import sys
p, a, b = sys.argv[1:4]
s = open(p).read()
assert s.count(a) == 1, (p, a)
open(p, "w").write(s.replace(a, b))
PYEOF
}
cut() {  # cut LABEL FILE OLD NEW: the bench in a fresh copy with OLD replaced by NEW in FILE
    copy; patch "$2" "$3" "$4"; run "$1"
}
copy; run as-is
cut no-small-triangles methods/glsl/splat_raster.glsl $'        for (uint k = k0; k < k1; ++k) sp_layer(' \
    $'        for (uint k = k0; k < k1 && false; ++k) sp_layer('
cut no-tiles methods/structures/splat.py $'            self._tiles(extra, capacity)\n' $'            pass\n'
cut small-triangles-no-store methods/glsl/splat_raster.glsl $'            ls_store(ls_list(k, ivec2(x, y), ls_size), pl.d0' \
    $'            if (pl.d0 + dot(pl.dd, q) != 1.0e30) continue;\n            ls_store(ls_list(k, ivec2(x, y), ls_size), pl.d0'
cut small-triangles-counter-only methods/glsl/linked_list.glsl $'    uint old = atomicExchange(ll_head[list], n);\n' \
    $'    if (z != 1.0e30) return n;\n    uint old = atomicExchange(ll_head[list], n);\n'
cut tiles-no-store methods/glsl/splat_tiles.glsl $'            uint n = ll_alloc(ls_capacity);\n' \
    $'            if (depth != 1.0e30) continue;\n            uint n = ll_alloc(ls_capacity);\n'
cut no-sort methods/structures/linked.py $'        if not self.sorted_insert and sort:\n' $'        if False:\n'
