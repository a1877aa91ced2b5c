// The long triangles of the splat build (ldbench/methods/structures/splat.py, splat_large = "tiles"): those
// layered/splat_raster.glsl left in its index list sp_large, rasterized in compute over tiles of SPLAT_TILE_X ×
// SPLAT_TILE_Y texels: one workgroup per (tile x, tile y, SP_TILE_LAYERS layers taken in turn), one invocation
// per texel. For each layer the long triangles whose snapped box meets the tile are binned (set up by the boxes
// pass, or here beyond its cap, with their edge functions at the tile's first texel): with LL_AGGREGATE each
// subgroup bins them for itself, a subgroup's width at a time, by ballot, and its lanes read each binned set-up
// from the lane that made it (no shared memory, no barrier: a tile's warps do not wait on each other; with
// SP_ALL_BOXED, when the boxes pass set up every long triangle, only the edge values at the tile and the flags by
// shuffle, the rest loaded from the set-up, the planes only once a texel is covered); without, the workgroup bins
// SP_TILE_N at a time in shared memory. Every invocation tests its texel centre against the binned ones by integer
// steps from there. Coverage is the hardware's at any size (layered/fill_rule.glsl fr_tile: exact int32 steps, edges
// longer than a thousand texels in doubles), depth and the near/far test are layered/splat_raster.glsl's
// (layered/splat_planes.glsl): the same fragments as the hardware draw of the "raster" mode.
// Runs after the compute splat has completed, so every invocation owns its texel's list for the pass: with
// yang2010's unsorted insert (linked layout) it pushes its fragments onto the head held in a register and
// writes the head once, with no atomic on it; any other store goes through ls_store.
// SP_TILE_SORT (structure.splat_sort, with that insert): the pass also sorts the lists it owns, so that the sort
// pass after it sorts only the lists left here. An invocation keeps its texel's fragments in registers,
// ascending, up to SP_SORT_R of them, and writes their nodes only at the end (with a payload, each node is
// allocated and its payload written at once; without, the nodes are allocated at the end in depth order, so
// that a tile's nodes of one rank lie together; a fragment beyond the registers is pushed onto the head in memory
// at once, and the head is loaded only at the end: no register holds it across the loop). At the end it adds the
// nodes the small triangles' splat linked at the head, while the registers hold them, and links what it holds in depth order, a node's depth and link in one store: the whole list when it
// fits; otherwise in front of the chain's remaining nodes, and the list is appended to sp_sort_list for the
// sort pass (layered/linked_list_sort.glsl, LL_SORT_LISTED; past sp_sort_cap lists, the sort pass sorts every list).
//
// Without a payload the held fragments' nodes are reserved at the end; with LL_AGGREGATE all of a warp's by one
// atomic, numbered by rank and, within a rank, by lane (as ll_alloc hands them out rank after rank).
// SP_BOXES_PASS: the pass before, one workgroup per layer: each of the first sp_box_cap long triangles set up in
// the layer (sp_tile_setup): its texel box, snapped vertices, edge biases and planes (sp_setup), so that a tile
// reads the set-up of only the triangles whose box meets it (most meet a few of the tiles), from the same
// arithmetic as their box; a tile sets up the triangles beyond sp_box_cap itself.
//
// Defines: as layered/splat_raster.glsl, SPLAT_TILE_X and SPLAT_TILE_Y (texels per tile side) and SP_TILE_N, their
// product (a literal: GLSL 4.30 sizes a workgroup by one), SP_TILE_LAYERS (layers a workgroup takes in turn:
// fewer workgroups to launch), SP_ALL_BOXED (the host's bound on the long triangles is within sp_box_cap:
// splat.py long_bound), FR_NARROW (layered/fill_rule.glsl; splat.py tiles_narrow).
#include "layered/write.glsl"

layout(local_size_x = SP_TILE_N) in;
layout(std430, binding = B_SPLAT_VERTICES) readonly buffer SplatVertices { float sp_vtx[]; };
layout(std430, binding = B_SPLAT_LARGE) readonly buffer SplatLarge { uint sp_cmd[16]; uint sp_large[]; };
uniform uint sp_parity;      // the pass's draw command: sp_cmd[5 sp_parity] counts the long triangles' indices
// per layer k, sp_box_cap boxes: (lo.x | lo.y << 16, hi.x | hi.y << 16), texels; (~0, 0) when empty
layout(std430, binding = B_SPLAT_BOXES) buffer SplatBoxes { uvec2 sp_box[]; };
// and, per box not empty, the triangle set up: its edges (e0, e1), (e2, f0), then (w0, d0, z0), (dd, dz) of SpPlanes
layout(std430, binding = B_SPLAT_SETUPS) buffer SplatSetups { uvec4 sp_setup[]; };
uniform uint sp_box_cap;
uniform uint sp_layers;      // layers of the structure
uniform ivec2 ls_size;       // W, H of one layer
uniform uint ls_capacity;    // nodes / fragments the structure holds
#include "layered/store.glsl"
#include "layered/fill_rule.glsl"
#include "layered/splat_planes.glsl"

#if LS_LAYOUT == 1 && !defined(LL_SORTED) && !defined(LS_PASS_COUNT)
#define SP_OWNED_HEAD 1
#if defined(SP_TILE_SORT)
#define SP_SORTING 1
#endif
#endif

#if defined(SP_SORTING)
#define SP_SORT_R 10
#define SP_LATE 0xFFFFFFFEu   // a held fragment whose node is allocated at the end (no payload)
layout(std430, binding = B_SPLAT_SORT) coherent buffer SplatSortLists { uint sp_sort_n; uint sp_sort_list[]; };
uniform uint sp_sort_cap;

// (z, n) into the ascending registers d, m holding c < SP_SORT_R entries (equal depths in no fixed order): carried
// up from the front, swapped with each greater entry, and put at c; the loop ends there (c + 1 steps: a tile's
// texels mostly hold as many fragments, so its warps rarely diverge here). Constant indices only, so that the
// arrays stay in registers.
void sp_insert(inout float d[SP_SORT_R], inout uint m[SP_SORT_R], uint c, float z, uint n) {
    for (int j = 0; j < SP_SORT_R; ++j) {
        if (uint(j) == c) { d[j] = z; m[j] = n; break; }
        if (d[j] > z) {
            float tz = d[j]; d[j] = z; z = tz;
            uint tn = m[j]; m[j] = n; n = tn;
        }
    }
}
// the same for a depth alone, in the tiles' loop (without a payload every fragment it holds is SP_LATE: sn is left
// as is): with the registers past c at +infinity, a min and a max a step and no branch; the last max drops one
void sp_insert_depth(inout float d[SP_SORT_R], float z) {
    for (int j = 0; j < SP_SORT_R; ++j) { float lo = min(d[j], z); z = max(d[j], z); d[j] = lo; }
}
#endif

vec3 sp_vertex(uint i) { return vec3(sp_vtx[7u * i], sp_vtx[7u * i + 1u], sp_vtx[7u * i + 2u]); }

// the triangle whose first vertex is v (3t) in layer k: its vertices, window positions and clip z, snapped
FrTri sp_tile_setup(uint k, uint v, out vec3 v0, out vec3 v1, out vec3 v2, out vec2 w0, out vec2 w1,
                    out vec2 w2, out vec3 z) {
    mat4 M = ls_layers[k].clip;
    vec2 hs = vec2(ls_size) * 0.5;
    v0 = sp_vertex(v); v1 = sp_vertex(v + 1u); v2 = sp_vertex(v + 2u);
    vec4 c0 = M * vec4(v0, 1.0), c1 = M * vec4(v1, 1.0), c2 = M * vec4(v2, 1.0);
    w0 = c0.xy * hs + hs; w1 = c1.xy * hs + hs; w2 = c2.xy * hs + hs;
    z = vec3(c0.z, c1.z, c2.z);
    return fr_setup(w0, w1, w2, ls_size);
}

// the set-up of the long triangle of box b (4 words of sp_setup): written by the boxes pass, read by the tiles
void sp_setup_store(uint b, FrTri t, SpPlanes pl) {
    sp_setup[4u * b] = uvec4(ivec4(t.f1 - t.f0, t.f2 - t.f1));
    sp_setup[4u * b + 1u] = uvec4(ivec4(t.f0 - t.f2, t.f0));
    sp_setup[4u * b + 2u] = floatBitsToUint(vec4(pl.w0, pl.d0, pl.z0));
    sp_setup[4u * b + 3u] = floatBitsToUint(vec4(pl.dd, pl.dz));
}
void sp_setup_edges(uint b, out ivec2 e0, out ivec2 e1, out ivec2 e2) {   // its edges, as stored
    uvec4 s0 = sp_setup[4u * b];
    e0 = ivec2(s0.xy); e1 = ivec2(s0.zw); e2 = ivec2(sp_setup[4u * b + 1u].xy);
}
FrTri sp_setup_tri(uint b) {   // its vertices and biases, what fr_tile reads
    ivec2 e0, e1, e2;
    sp_setup_edges(b, e0, e1, e2);
    FrTri t;
    t.f0 = ivec2(sp_setup[4u * b + 1u].zw); t.f1 = t.f0 + e0; t.f2 = t.f1 + e1;
    t.b0 = sp_bias(e0); t.b1 = sp_bias(e1); t.b2 = sp_bias(e2);
    return t;
}
SpPlanes sp_setup_planes(uint b) {
    vec4 p0 = uintBitsToFloat(sp_setup[4u * b + 2u]), p1 = uintBitsToFloat(sp_setup[4u * b + 3u]);
    return SpPlanes(p0.xy, p0.z, p0.w, p1.xy, p1.zw);
}

#if defined(SP_BOXES_PASS)
void main() {
    uint k = gl_WorkGroupID.x, n = min(sp_cmd[5u * sp_parity] / 3u, sp_box_cap);
    for (uint i = gl_LocalInvocationIndex; i < n; i += uint(SP_TILE_N)) {
        vec3 v0, v1, v2, z;
        vec2 w0, w1, w2;
        FrTri tri = sp_tile_setup(k, sp_large[3u * i], v0, v1, v2, w0, w1, w2, z);
        bool empty = !tri.ok || any(greaterThan(tri.lo, tri.hi));
        uvec2 lo = uvec2(tri.lo), hi = uvec2(tri.hi);
        uint b = k * sp_box_cap + i;
        sp_box[b] = empty ? uvec2(0xFFFFFFFFu, 0u) : uvec2(lo.x | lo.y << 16, hi.x | hi.y << 16);
        if (empty) continue;
        sp_setup_store(b, tri, sp_planes(k, tri.cw, tri.f0, tri.f1, tri.f2, w0, w1, w2, z.x, z.y, z.z, v0, v1, v2));
    }
}
#else
#if LS_PAYLOAD > 0 || !defined(SP_OWNED_HEAD)
#define SP_ATTRIBUTES 1   // the stores read the triangle's normal and material
#endif
struct SpBinned {
    FrTile tri;
    SpPlanes pl;
#if defined(SP_ATTRIBUTES)
    vec3 normal;
    uint material;
#endif
};
// whether the texel box lo .. hi meets the tile t0 .. t1
bool sp_meets(ivec2 lo, ivec2 hi, ivec2 t0, ivec2 t1) { return all(lessThanEqual(max(lo, t0), min(hi, t1))); }
// the same for a box packed by the boxes pass
bool sp_box_meets(uvec2 b, ivec2 t0, ivec2 t1) {
    return sp_meets(ivec2(b.x & 0xFFFFu, b.x >> 16), ivec2(b.y & 0xFFFFu, b.y >> 16), t0, t1);
}

#if defined(LL_AGGREGATE)
#define SP_WARP_BIN 1   // each subgroup bins for itself (the header)
#define SP_CHUNK gl_SubGroupSizeARB
#define SP_CHUNK_LANE gl_SubGroupInvocationARB
// lane j's edge values at the tile, flags and attributes (j the same in every lane): what every read of a binned
// set-up shuffles; its edges and planes are left to the caller
SpBinned sp_bin_read_lane(SpBinned b, uint j) {
    SpBinned r;
    r.tri.c = readInvocationARB(b.tri.c, j);
    uint f = readInvocationARB((b.tri.wide ? 1u : 0u) | (b.tri.full ? 2u : 0u), j);
    r.tri.wide = (f & 1u) != 0u; r.tri.full = (f & 2u) != 0u; r.tri.none = false;
#if defined(SP_ATTRIBUTES)
    r.normal = readInvocationARB(b.normal, j);
    r.material = readInvocationARB(b.material, j);
#endif
    return r;
}
SpBinned sp_bin_read(SpBinned b, uint j) {   // lane j's set-up, all of it by shuffle
    SpBinned r = sp_bin_read_lane(b, j);
    r.tri.e0 = readInvocationARB(b.tri.e0, j);
    r.tri.e1 = readInvocationARB(b.tri.e1, j);
    r.tri.e2 = readInvocationARB(b.tri.e2, j);
    r.pl.w0 = readInvocationARB(b.pl.w0, j);
    r.pl.d0 = readInvocationARB(b.pl.d0, j);
    r.pl.z0 = readInvocationARB(b.pl.z0, j);
    r.pl.dd = readInvocationARB(b.pl.dd, j);
    r.pl.dz = readInvocationARB(b.pl.dz, j);
    return r;
}
#if defined(SP_ALL_BOXED)
// lane j's set-up of the long triangle e (both the same in every lane) when the boxes pass set up every long
// triangle: the edge values at the tile and the flags by shuffle, the edges loaded from the boxes pass's set-up (one
// address in every lane), so that a warp holds 4 words of each binned set-up across its loop, not 18; its planes are
// loaded by sp_bin_planes only where a texel is covered
SpBinned sp_bin_get(SpBinned b, uint j, uint k, uint e) {
    SpBinned r = sp_bin_read_lane(b, j);
    uint i = k * sp_box_cap + e;
#if defined(FR_NARROW)
    sp_setup_edges(i, r.tri.e0, r.tri.e1, r.tri.e2);   // no vertex to rebuild
#else
    fr_tile_edges(sp_setup_tri(i), r.tri.wide, r.tri.e0, r.tri.e1, r.tri.e2);
#endif
    return r;
}
SpPlanes sp_bin_planes(SpBinned b, uint k, uint e) { return sp_setup_planes(k * sp_box_cap + e); }
#else
SpBinned sp_bin_get(SpBinned b, uint j, uint k, uint e) { return sp_bin_read(b, j); }
#endif
#endif
#if !defined(SP_WARP_BIN) || !defined(SP_ALL_BOXED)
#define SP_PLANES_BINNED 1   // the planes travel with each binned set-up (else loaded where a texel is covered)
SpPlanes sp_bin_planes(SpBinned b, uint k, uint e) { return b.pl; }
#endif
#if !defined(SP_WARP_BIN)
#define SP_CHUNK uint(SP_TILE_N)
#define SP_CHUNK_LANE gl_LocalInvocationIndex
shared SpBinned sp_bin[SP_TILE_N];
shared uint sp_bin_n;
#endif

// the long triangle e (of n_large) set up in layer k for the tile t0 .. t1: b.tri.none when it misses the tile
void sp_bin_setup(uint k, uint e, uint n_large, ivec2 t0, ivec2 t1, ivec2 span, int lim, out SpBinned b) {
    b.tri.none = true;
    if (e < sp_box_cap && e < n_large) {   // set up by the boxes pass
        uint i = k * sp_box_cap + e;
        if (sp_box_meets(sp_box[i], t0, t1)) {
            b.tri = fr_tile(sp_setup_tri(i), t0, span, lim);
#if defined(SP_PLANES_BINNED)
            if (!b.tri.none) b.pl = sp_setup_planes(i);
#endif
        }
    }
#if !defined(SP_ALL_BOXED)
    else if (e < n_large) {                // beyond the boxes pass's cap: set up here
        vec3 v0, v1, v2, z;
        vec2 w0, w1, w2;
        FrTri tri = sp_tile_setup(k, sp_large[3u * e], v0, v1, v2, w0, w1, w2, z);
        if (tri.ok && sp_meets(tri.lo, tri.hi, t0, t1)) b.tri = fr_tile(tri, t0, span, lim);
        if (!b.tri.none) b.pl = sp_planes(k, tri.cw, tri.f0, tri.f1, tri.f2, w0, w1, w2, z.x, z.y, z.z, v0, v1, v2);
    }
#endif
#if defined(SP_ATTRIBUTES)
    if (!b.tri.none) {
        uint v = sp_large[3u * e];   // the triangle's first vertex (3t)
        b.normal = vec3(sp_vtx[7u * v + 3u], sp_vtx[7u * v + 4u], sp_vtx[7u * v + 5u]);
        b.material = uint(sp_vtx[7u * v + 6u] + 0.5);
    }
#endif
}


// tile gl_WorkGroupID.xy of layer k
void sp_tile(uint k) {
    uint lid = gl_LocalInvocationIndex;
    const ivec2 tile = ivec2(SPLAT_TILE_X, SPLAT_TILE_Y);
    const int lim = (1 << 30) / (SP_ONE * (SPLAT_TILE_X + SPLAT_TILE_Y));   // fr_tile's longest stepped edge
    const ivec2 span = (tile - 1) * SP_ONE;                                  // and its last texel's step
    ivec2 t0 = ivec2(gl_WorkGroupID.xy) * tile;
    ivec2 t1 = t0 + tile - 1;   // the triangles' boxes are clamped to the layer
    ivec2 d = ivec2(int(lid) % SPLAT_TILE_X, int(lid) / SPLAT_TILE_X);
    ivec2 px = t0 + d;
    d *= SP_ONE;
    bool inside = all(lessThan(px, ls_size));
    uint list = inside ? ls_list(k, px, ls_size) : 0u;
#if defined(SP_OWNED_HEAD)
    uint head = LL_EOL, head0 = LL_EOL;   // the list's head, loaded at the first fragment
    bool loaded = false;
#endif
#if defined(SP_SORTING)
    float sd[SP_SORT_R];   // the texel's fragments held, ascending (+infinity past them)
    uint sn[SP_SORT_R];    // and their nodes (without a payload, SP_LATE until the chain's nodes join)
    for (int j = 0; j < SP_SORT_R; ++j) { sd[j] = uintBitsToFloat(0x7F800000u); sn[j] = LS_PAYLOAD == 0 ? SP_LATE : LL_EOL; }
    uint held = 0u;
#endif
    uint n_large = sp_cmd[5u * sp_parity] / 3u;
    for (uint c = 0u; c < n_large; c += SP_CHUNK) {
#if !defined(SP_WARP_BIN)
        if (lid == 0u) sp_bin_n = 0u;
        barrier();
#endif
        uint e = c + SP_CHUNK_LANE;
        SpBinned bt;
        sp_bin_setup(k, e, n_large, t0, t1, span, lim, bt);
#if defined(SP_WARP_BIN)
        uint64_t bins = ballotARB(!bt.tri.none);
        uint m = ls_count(bins);
#else
        if (!bt.tri.none) sp_bin[atomicAdd(sp_bin_n, 1u)] = bt;
        barrier();
        uint m = sp_bin_n;
#endif
        for (uint i = 0u; i < m; ++i) {
#if defined(SP_WARP_BIN)
            uvec2 bw = unpackUint2x32(bins);
            uint j = bw.x != 0u ? uint(findLSB(bw.x)) : 32u + uint(findLSB(bw.y));
            bins &= bins - 1ul;
            uint eb = c + j;
            SpBinned b = sp_bin_get(bt, j, k, eb);
#else
            uint eb = 0u;   // unused: the planes were binned with the set-up
            SpBinned b = sp_bin[i];
#endif
            if (!inside || (!b.tri.full && !fr_tile_covers(b.tri, d, px))) continue;
            SpPlanes pl = sp_bin_planes(b, k, eb);
            vec2 q = vec2(px) + 0.5 - pl.w0;
            if (abs(pl.z0 + dot(pl.dz, q)) > 1.0) continue;
            float depth = pl.d0 + dot(pl.dd, q);
#if defined(SP_OWNED_HEAD)
#if defined(SP_SORTING) && LS_PAYLOAD == 0
            if (held < uint(SP_SORT_R)) { sp_insert_depth(sd, depth); ++held; continue; }
#endif
            uint n = ll_alloc(ls_capacity);
            if (n == LL_EOL) continue;
#if LS_PAYLOAD > 0
            uint w[LS_PAYLOAD];
            ls_payload_words(b.normal, b.material, w);
            ll_set_payload(n, w);
#endif
#if defined(SP_SORTING) && LS_PAYLOAD > 0
            if (held < uint(SP_SORT_R)) { sp_insert(sd, sn, held, depth, n); ++held; continue; }
#endif
#if defined(SP_SORTING)
            ll_set_node(n, depth, ll_head[list]);   // beyond the registers: pushed in memory (the list is this lane's)
            ll_head[list] = n;
#else
            if (!loaded) { head = ll_head[list]; head0 = head; loaded = true; }
            ll_set_node(n, depth, head);
            head = n;
#endif
#else
            ls_store(list, depth, b.normal, b.material);
#endif
        }
#if !defined(SP_WARP_BIN)
        barrier();
#endif
    }
#if defined(SP_SORTING)
    if (!inside) return;
    head = ll_head[list]; head0 = head;
    // the chain at the head (the small triangles' nodes, and this pass's beyond the registers) while it fits
    bool own = held > 0u, in_order = true;
    float prev = -uintBitsToFloat(0x7F800000u);
    uint i = head;
    for (int j = 0; j < SP_SORT_R; ++j) {
        if (i == LL_EOL || held >= uint(SP_SORT_R)) break;
        LLNode nd = ll_node(i);
        in_order = in_order && nd.depth >= prev;
        prev = nd.depth;
        sp_insert(sd, sn, held, nd.depth, i);
        ++held;
        i = nd.next;
    }
    if (i != LL_EOL) {   // longer than the registers: the rest of the chain from i, sorted by the sort pass
        uint e = atomicAdd(sp_sort_n, 1u);
        if (e < sp_sort_cap) sp_sort_list[e] = list;
    } else if (!own && in_order) {
        return;          // only the chain, already in order: nothing changes
    }
#if LS_PAYLOAD == 0 && defined(LL_AGGREGATE)
    // the held fragments' nodes, in depth order (a warp's nodes of one rank together), in one reservation per warp
    uint total = 0u, base;
    for (int j = 0; j < SP_SORT_R; ++j) total += ls_count(ballotARB(uint(j) < held && sn[j] == SP_LATE));
    LS_SUBGROUP_ADD(ll_counters[LL_C_NODES], ballotARB(true), total, base)
    for (int j = 0; j < SP_SORT_R; ++j) {
        bool late = uint(j) < held && sn[j] == SP_LATE;
        uint64_t b = ballotARB(late);
        if (late) sn[j] = ll_claim(base + ls_count(b & gl_SubGroupLtMaskARB), ls_capacity);
        base += ls_count(b);
    }
#elif LS_PAYLOAD == 0
    for (int j = 0; j < SP_SORT_R; ++j)   // the held fragments' nodes, in depth order: a tile's nodes of one rank together
        if (uint(j) < held && sn[j] == SP_LATE) sn[j] = ll_alloc(ls_capacity);
#endif
    for (int j = SP_SORT_R - 1; j >= 0; --j) {   // linked from the back; a fragment the full pool refused is left out
        if (uint(j) >= held || sn[j] == LL_EOL) continue;
        ll_set_node(sn[j], sd[j], i);
        i = sn[j];
    }
    head = i;
#endif
#if defined(SP_OWNED_HEAD)
    if (head != head0) ll_head[list] = head;
#endif
}

void main() {   // SP_TILE_LAYERS layers of the tile, one after the other
    uint k0 = gl_WorkGroupID.z * uint(SP_TILE_LAYERS);
    for (uint k = k0; k < min(k0 + uint(SP_TILE_LAYERS), sp_layers); ++k) sp_tile(k);
}
#endif
