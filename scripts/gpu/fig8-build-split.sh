#!/usr/bin/env bash
# Where the default Figure 8 build's time goes (docs/results/fast-defaults-h200.md): the build of
# scripts/gpu/fast_builds_bench.py (fig8 part: 512 maps of 200² on atrium 260k) timed in throw-away copies
# of the checkout with one part cut: (1) as is; (2) without the compute splat's small triangles; (3)
# without the long triangles' tiles; (4) the small triangles testing coverage but storing nothing; (5) the
# small triangles' stores stopped after the node counter's atomic (yang2010's insert, which only they use);
# (6) the tiles testing coverage but storing nothing; (7) without the sort pass. Cut builds store fewer
# fragments or leave lists unsorted: their rows read "degraded", and only their times mean anything. The
# checkout itself is not touched.
# The AO pass of the default Figure 8 frame (scripts/gpu/fast_defaults.py --only fig8 --labels default), cut
# the same way: (1) as is; (2) each map's walk cut to its list's first node; (3) to the head only (no node
# read); (4) to the query (the list's index, no list read). Their images are wrong; their ao times are not.
# The tiles' sort of the lists (structure.splat_sort, split "sort"): its build alone as is and with the tiles
# holding 4, 6 or 8 nodes instead of 10, and the default Figure 8 frame as is and with the held fragments'
# nodes allocated when found (as with a payload) instead of at the end in depth order. The long triangles'
# tiles (split "tiles"): the build alone as is and with one of its parts undone: every texel's edge functions
# in doubles, no tile found covered fully or not at all, no pass of the boxes, the normal and material binned
# though no store reads them, 8 nodes held instead of 10, and the register insert from the back (since the
# eleventh run only the insert of the small triangles' chain: the loop's is sp_insert_depth). The parts of
# the eleventh and fourteenth runs (split "undo"): the build alone as is and with one undone: the small triangles'
# fragments stored at once (no buffer in shared memory), that buffer two per invocation (not four), the queue
# eight pairs per invocation (not six), the fragments buffered with their triangle (not without a payload), one
# chunk of triangles per workgroup (not four), the first phase of their queue in fixed point (not the float test),
# the tiles' held nodes reserved rank by rank (not in one atomic per warp), one layer per tiles' workgroup (not
# 2), the tiles' loop inserting nodes with the depths, or with branches (not a min and a max), the head held in a
# register, the edges rebuilt from the vertices (approximately: here the vertices are first rebuilt from the
# stored edges), and every tile setting up its long triangles (not reading the
# boxes pass's set-ups), and (fifteenth run) the planes of a binned long triangle loaded before its coverage test. These
# copies build the same lists; only the times differ. Split "passes" (the twelfth run): each dispatch's time (build_passes.py;
# PASSES_ARGS: its arguments) as is, and with parts cut out, whose lists are wrong: the small triangles
# projected but none queued, nothing projected, the tiles without long triangles, the tiles reading no chain;
# and the thirteenth run's: the head stored plainly, not exchanged; the queued fragments not stored; the long
# triangles binned but their texels not walked; the tiles' nodes and heads not written (their atomics kept).
#
# Usage, from the project root with its Python environment set up:
#     bash scripts/gpu/fig8-build-split.sh [--dry]
# LDBENCH_SPLIT: which splits (default "build ao"; also "sort", "tiles", "undo", "passes"); LDBENCH_SPLIT_VARIANT: the build's
# variant of fast_builds_bench.py for the build split (default splat/linked-yang-queue-batch16-aggregate: the Figure 8
# default without the tiles' sort, whose parts its cuts address).
set -u
PY="${PYTHON:-python3}"
src=$PWD
W="$(mktemp -d "${TMPDIR:-/tmp}/fig8-split.XXXXXX")"
trap 'rm -rf "$W"' EXIT
V=${LDBENCH_SPLIT_VARIANT:-splat/linked-yang-queue-batch16-aggregate}
ARGS=("$@")
stale() {  # stale LABEL: true (and says so) when a patch of this copy failed: its times would be the unpatched build's
    [ -e "$W/tree/.stale" ] && echo "== $1: not run, a patch of it no longer applies"
}
run() {  # run LABEL: the bench in the copy, with this script's arguments
    stale "$1" && return
    echo "== $1"
    (cd "$W/tree" && export PYTHONPATH="$PWD" &&
     timeout 200 "$PY" scripts/gpu/fast_builds_bench.py "$W/out-$1" fig8 --variants "$V" ${ARGS[@]+"${ARGS[@]}"} 2>&1 |
     grep -o "variant=[^ ]* build_ms=[^ ]*\|stages=[^ ]*" | paste - -)
}
frame() {  # frame LABEL: the default Figure 8 frame in the copy; its stage times
    stale "$1" && return
    echo "== $1"
    (cd "$W/tree" && export PYTHONPATH="$PWD" &&
     timeout 250 "$PY" scripts/gpu/fast_defaults.py "$W/out-$1" --only fig8 --labels default ${ARGS[@]+"${ARGS[@]}"} 2>&1 |
     grep "^fig8 default total")
}
passes() {  # passes LABEL: each dispatch's GPU time in one build of the copy (build_passes.py)
    stale "$1" && return
    echo "== $1"
    (cd "$W/tree" && export PYTHONPATH="$PWD" &&
     timeout 200 "$PY" scripts/gpu/build_passes.py ${PASSES_ARGS:-} 2>&1 | grep "ms")
}
copy() {  # the package's folders and the scripts, as they are in the working tree
    rm -rf "$W/tree"; mkdir -p "$W/tree"
    for d in ldbench scripts suites pyproject.toml; do cp -r "$src/$d" "$W/tree/"; done
}
patch() {  # patch FILE OLD NEW (exactly one occurrence; else the copy is marked stale)
    "$PY" - "$W/tree/$1" "$2" "$3" <<'PYEOF' || touch "$W/tree/.stale"
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
for split in ${LDBENCH_SPLIT-build ao}; do
if [ "$split" = build ]; then
copy; run as-is
cut no-small-triangles ldbench/methods/glsl/layered/splat_raster.glsl $'            if (!sp_long(t, v0, v1, v2)) {' \
    $'            if (!sp_long(t, v0, v1, v2) && false) {'
cut no-tiles ldbench/methods/structures/splat.py $'            self._tiles(extra, capacity)\n' $'            pass\n'
cut small-triangles-no-store ldbench/methods/glsl/layered/splat_raster.glsl $'            sp_store(t, ls_list(k, ivec2(x, y), ls_size), pl.d0' \
    $'            if (pl.d0 + dot(pl.dd, q) != 1.0e30) continue;\n            sp_store(t, ls_list(k, ivec2(x, y), ls_size), pl.d0'
cut small-triangles-counter-only ldbench/methods/glsl/layered/linked_list.glsl $'    uint old = atomicExchange(ll_head[list], n);\n' \
    $'    if (z != 1.0e30) return n;\n    uint old = atomicExchange(ll_head[list], n);\n'
cut tiles-no-store ldbench/methods/glsl/layered/splat_tiles.glsl $'            uint n = ll_alloc(ls_capacity);\n' \
    $'            if (depth != 1.0e30) continue;\n            uint n = ll_alloc(ls_capacity);\n'
cut no-sort ldbench/methods/structures/linked.py $'        if not self.sorted_insert and sort:\n' $'        if False:\n'
cut tiles-no-coverage-loop ldbench/methods/glsl/layered/splat_tiles.glsl $'        uint m = sp_bin_n;\n' \
    $'        uint m = sp_bin_n == 0xFFFFFFFFu ? 1u : 0u;\n'
fi
if [ "$split" = sort ]; then
TS=splat/linked-yang-queue-batch16-aggregate-tilesort
copy; V=$TS run sort-build-as-is
for r in 4 6 8; do V=$TS cut "sort-build-$r-nodes" ldbench/methods/glsl/layered/splat_tiles.glsl '#define SP_SORT_R 10' "#define SP_SORT_R $r"; done
copy; frame sort-frame-as-is
copy; patch ldbench/methods/glsl/layered/splat_tiles.glsl $'#if defined(SP_SORTING) && LS_PAYLOAD == 0\n            if (held' \
    $'#if 0\n            if (held'
patch ldbench/methods/glsl/layered/splat_tiles.glsl $'#if defined(SP_SORTING) && LS_PAYLOAD > 0\n' $'#if defined(SP_SORTING)\n'
frame sort-frame-nodes-when-found
fi
if [ "$split" = tiles ]; then
# the long triangles' tiles (layered/splat_tiles.glsl, layered/fill_rule.glsl fr_tile) with one of their parts undone
TS=splat/linked-yang-queue-batch16-aggregate-tilesort
copy; V=$TS run tiles-as-is
copy; patch ldbench/methods/glsl/layered/fill_rule.glsl '    r.wide = max(m.x, m.y) > lim;' '    r.wide = true;'
patch ldbench/methods/structures/splat.py '            tiles["FR_NARROW"] = 1' '            pass'; V=$TS run tiles-edges-in-doubles
copy; patch ldbench/methods/glsl/layered/fill_rule.glsl '    r.full = r.c.x' '    r.full = false && r.c.x'
patch ldbench/methods/glsl/layered/fill_rule.glsl '    r.none = r.c.x' '    r.none = false && r.c.x'; V=$TS run tiles-no-whole-tile-flags
V=$TS cut tiles-no-boxes-pass ldbench/methods/structures/splat.py 'BOX_CAP = 256 ' 'BOX_CAP = 0 '
V=$TS cut tiles-attributes-binned ldbench/methods/glsl/layered/splat_tiles.glsl '#if LS_PAYLOAD > 0 || !defined(SP_OWNED_HEAD)' '#if 1'
V=$TS cut tiles-8-nodes ldbench/methods/glsl/layered/splat_tiles.glsl '#define SP_SORT_R 10' '#define SP_SORT_R 8'
V=$TS cut tiles-insert-from-the-back ldbench/methods/glsl/layered/splat_tiles.glsl \
    $'    for (int j = 0; j < SP_SORT_R; ++j) {\n        if (uint(j) == c) { d[j] = z; m[j] = n; break; }\n        if (d[j] > z) {\n            float tz = d[j]; d[j] = z; z = tz;\n            uint tn = m[j]; m[j] = n; n = tn;\n        }\n    }' \
    $'    for (int j = SP_SORT_R - 1; j > 0; --j) {\n        if (uint(j) > c) continue;\n        if (d[j - 1] > z) { d[j] = d[j - 1]; m[j] = m[j - 1]; }\n        else if (uint(j) == c || d[j] > z) { d[j] = z; m[j] = n; }\n    }\n    if (c == 0u || d[0] > z) { d[0] = z; m[0] = n; }'
fi
if [ "$split" = undo ]; then
TS=splat/linked-yang-queue-batch16-aggregate-tilesort
R=ldbench/methods/glsl/layered/splat_raster.glsl; T=ldbench/methods/glsl/layered/splat_tiles.glsl
copy; V=$TS run undo-as-is
V=$TS cut undo-fragments-stored-at-once $R '    uint slot = atomicAdd(sp_frags, 1u);' '    uint slot = uint(SP_FRAG_N);'
V=$TS cut undo-fragment-buffer-2x $R '#define SP_FRAG_N (SPLAT_GROUP * 4)' '#define SP_FRAG_N (SPLAT_GROUP * 2)'
V=$TS cut undo-queue-8x $R '#define SP_QUEUE_N (SPLAT_GROUP * 6)' '#define SP_QUEUE_N (SPLAT_GROUP * 8)'
V=$TS cut undo-fragments-with-triangle $R $'#if LS_PAYLOAD > 0\n#define SP_FRAG uvec3' $'#if 1\n#define SP_FRAG uvec3'
V=$TS cut undo-one-chunk-per-workgroup ldbench/methods/structures/splat.py 'GROUP_CHUNKS = 4 ' 'GROUP_CHUNKS = 1 '
V=$TS cut undo-queue-in-fixed-point $R $'                    if (!sp_reaches(k0, k - k0, v0, v1, v2)) continue;' \
    $'                    SpPair p;\n                    if (!sp_project(k, v0, v1, v2, p)) continue;'
V=$TS cut undo-nodes-rank-by-rank $T '#if LS_PAYLOAD == 0 && defined(LL_AGGREGATE)' '#if 0'
V=$TS cut undo-one-layer-per-workgroup ldbench/methods/structures/splat.py 'TILE_LAYERS = 2 ' 'TILE_LAYERS = 1 '
V=$TS cut undo-insert-with-nodes $T '{ sp_insert_depth(sd, depth); ++held; continue; }' \
    '{ sp_insert(sd, sn, held, depth, SP_LATE); ++held; continue; }'
copy; patch $T $'void sp_insert_depth(inout float d[SP_SORT_R], float z) {\n    for (int j = 0; j < SP_SORT_R; ++j) { float lo = min(d[j], z); z = max(d[j], z); d[j] = lo; }' \
    $'void sp_insert_depth(inout float d[SP_SORT_R], uint c, float z) {\n    for (int j = 0; j < SP_SORT_R; ++j) {\n        if (uint(j) == c) { d[j] = z; break; }\n        if (d[j] > z) { float tz = d[j]; d[j] = z; z = tz; }\n    }'
patch $T '{ sp_insert_depth(sd, depth); ++held; continue; }' '{ sp_insert_depth(sd, held, depth); ++held; continue; }'
V=$TS run undo-insert-with-branches
copy; patch $T $'            ll_set_node(n, depth, ll_head[list]);   // beyond the registers: pushed in memory (the list is this lane\'s)\n            ll_head[list] = n;' \
    $'            if (!loaded) { head = ll_head[list]; head0 = head; loaded = true; }\n            ll_set_node(n, depth, head);\n            head = n;'
patch $T '    head = ll_head[list]; head0 = head;' '    if (!loaded) { head = ll_head[list]; head0 = head; }'
V=$TS run undo-head-in-a-register
V=$TS cut undo-edges-from-vertices $T $'#if defined(FR_NARROW)\n    sp_setup_edges(i,' $'#if 0\n    sp_setup_edges(i,'
copy; patch $T '    if (e < sp_box_cap && e < n_large) {   // set up by the boxes pass' '    if (false) {'
patch $T '    else if (e < n_large) {                // beyond' \
    '    else if (e < n_large && (e >= sp_box_cap || sp_box_meets(sp_box[k * sp_box_cap + e], t0, t1))) {  //'
patch ldbench/methods/structures/splat.py '            tiles["SP_ALL_BOXED"] = 1' '            pass'
V=$TS run undo-tiles-set-up-per-tile
V=$TS cut undo-planes-before-coverage $T $'            if (!inside || (!b.tri.full && !fr_tile_covers(b.tri, d, px))) continue;\n            SpPlanes pl = sp_bin_planes(b, k, eb);' \
    $'            SpPlanes pl = sp_bin_planes(b, k, eb);\n            if (!inside || (!b.tri.full && !fr_tile_covers(b.tri, d, px))) continue;'
fi
if [ "$split" = passes ]; then
R=ldbench/methods/glsl/layered/splat_raster.glsl; T=ldbench/methods/glsl/layered/splat_tiles.glsl
copy; passes passes-as-is
Q='if (!sp_reaches(k0, k - k0, v0, v1, v2)) continue;'
copy; patch $R "$Q" 'if (!sp_reaches(k0, k - k0, v0, v1, v2) || n_layers > 0u) continue;'
passes passes-small-projected-none-queued
copy; patch $R "$Q" 'if (n_layers > 0u || !sp_reaches(k0, k - k0, v0, v1, v2)) continue;'
passes passes-small-nothing-projected
copy; patch ldbench/methods/glsl/layered/linked_list.glsl '    uint old = atomicExchange(ll_head[list], n);' \
    '    uint old = LL_EOL; ll_head[list] = n;'
passes passes-small-plain-head-store
copy; patch $R '            SP_FRAG_STORE(f);' '            if (f.y == 0x7FC00001u) SP_FRAG_STORE(f);'
passes passes-small-queued-not-stored
copy; patch $T '    uint n_large = sp_cmd[5u * sp_parity] / 3u;' '    uint n_large = sp_layers > 0u ? 0u : sp_cmd[5u * sp_parity] / 3u;'
passes passes-tiles-no-long-triangles
copy; patch $T '        if (i == LL_EOL || held >= uint(SP_SORT_R)) break;' \
    '        if (i == LL_EOL || held >= uint(SP_SORT_R) || sp_layers > 0u) break;'
passes passes-tiles-no-chain
copy; patch $T '        for (uint i = 0u; i < m; ++i) {' \
    '        if (m == 0x7FFFFFFFu) ll_head[0] = 1u; for (uint i = 0u; i < 0u; ++i) {'
passes passes-tiles-binned-not-walked
copy; patch $T '    if (head != head0) ll_head[list] = head;' '    if (head != head0 && sd[0] == 1.2345e-30) ll_head[list] = head;'
patch $T '        ll_set_node(sn[j], sd[j], i);' '        if (sd[j] == 1.2345e-30) ll_set_node(sn[j], sd[j], i);'
passes passes-tiles-no-node-writes
fi
if [ "$split" = ao ]; then
W_AO='            float t = ldm_walk(q[j], cs[j] > 0.0 ? 1.0 : -1.0, first[j]);'
copy; frame ao-as-is
copy; patch ldbench/methods/ldm/ao.glsl "$W_AO" \
    '            float t = first[j] == LS_END ? -1.0 : ls_depth(first[j]) - q[j].zx;'; frame ao-first-node-only
copy; patch ldbench/methods/ldm/ao.glsl "$W_AO" \
    '            float t = first[j] == LS_END ? -1.0 : float(first[j] & 1u);'; frame ao-head-only
copy; patch ldbench/methods/ldm/ao.glsl "$W_AO" \
    '            float t = q[j].zx + float(q[j].list & 1u) - 1.0;'; frame ao-query-only
fi
done
