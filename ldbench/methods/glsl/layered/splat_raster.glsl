// Compute-shader rasterizer of small triangles into a layered structure (ldbench/methods/structures/splat.py,
// build = "splat"): one invocation per (triangle, batch of SPLAT_BATCH layers), every covered texel
// stored with the same ls_store as the hardware raster (layered/store.glsl).
// SPLAT_QUEUE (structure.splat_queue): a workgroup's invocations first project their triangles into the
// batch's layers and queue, in shared memory, the pairs whose box may hold a texel centre (a few in a hundred;
// tested in floats, sp_reaches); then consecutive invocations rasterize the queued pairs, so that the lanes of
// a warp that have a box to walk are together, not scattered among the rejected pairs, and put the fragments
// in shared memory; then consecutive invocations store them, so that a warp's stores are not spread over its
// lanes' unequal boxes. The same fragments.
//
// Coverage is the hardware's (gbuffer/fill_rule.glsl, shared with the compute G-buffer): window coordinates
// snapped to LS_SUBPIXEL_BITS of fixed point, samples at texel centres, exact integer edge functions, and
// the edge classes this GPU includes. Zero-area triangles (after snapping) cover nothing.
// Depth and clip z are the planes through the three vertices evaluated at the texel centre, as the
// hardware interpolates: through the snapped vertices with SPLAT_SNAPPED_PLANE (NVIDIA), else through the
// given ones (llvmpipe); a sliver's depths differ by up to ~1 % between the two. A sample outside the
// near/far planes (|z| > 1) is dropped as clipping would. Layers must be affine (w = 1, orthographic
// maps: checked on the host).
//
// Large triangles: one whose longest edge, times splat_scale (the most texels per world unit of any
// layer), exceeds splat_max texels is left to a second pass (layered/splat_tiles.glsl, or the hardware): the
// invocation of its first layer batch appends its vertex indices to sp_large, the index list of both
// (sp_cmd holds the hardware's two indirect draw commands, one per pass parity: sp_cmd[5 sp_parity] counts this
// pass's indices; the first invocation zeroes the other's for the next pass). splat_max <= 64 keeps
// every edge function within int32 (coordinate differences < 65 * 256 = 2^14.1, products < 2^29.1).
//
// Defines: as layered/build.glsl (LS_LAYOUT, LS_PASS_COUNT, LS_EMIT, LL_SORTED, LS_PAYLOAD / LS_PL_*,
// LL_AGGREGATE), SPLAT_BATCH (layers per invocation), SPLAT_GROUP (invocations per workgroup), SPLAT_QUEUE,
// LS_SUBPIXEL_BITS, SPLAT_TOP/BOTTOM/LEFT/RIGHT, SPLAT_SNAPPED_PLANE (0 or 1), SPLAT_WIN_N (layers of a batch whose
// window rows the queue keeps in shared memory).
#include "layered/write.glsl"

layout(local_size_x = SPLAT_GROUP) in;
// geometry.vertices (ldbench/methods/gbuffer.py): per vertex position (3), face normal (3), material (1); the positions
// alone, what every layer batch loads again: geometry.triangle_positions, per triangle three vec4
layout(std430, binding = B_SPLAT_VERTICES) readonly buffer SplatVertices { float sp_vtx[]; };
layout(std430, binding = B_SPLAT_POSITIONS) readonly buffer SplatPositions { vec4 sp_pos[]; };
layout(std430, binding = B_SPLAT_LARGE) buffer SplatLarge { uint sp_cmd[16]; uint sp_large[]; };
#if defined(SP_ZERO_SORT)
// the lists the tiles leave to the sort pass (layered/splat_tiles.glsl): emptied here, before the tiles' pass
layout(std430, binding = B_SPLAT_SORT) writeonly buffer SplatSortLists { uint sp_sort_n; uint sp_sort_list[]; };
#endif
uniform ivec2 ls_size;       // W, H of one layer
uniform uint ls_capacity;    // nodes / fragments the structure holds
uniform uint n_triangles;
uniform uint n_layers;
uniform float splat_scale;   // texels per world unit, the largest of any layer
uniform float splat_max;     // longest edge (texels) rasterized here
uniform vec3 sp_extent;      // the largest |coordinate| of the scene's vertices per axis (the queue's margin)
uniform uint sp_parity;      // the pass's draw command (0 or 1)
#include "layered/store.glsl"
#include "gbuffer/fill_rule.glsl"
#include "layered/splat_planes.glsl"

// The pair (triangle, layer k) projected and snapped; false when its box holds no texel centre (most pairs)
struct SpPair { vec2 w0, w1, w2; float z0, z1, z2; ivec2 f0, f1, f2; int area; ivec2 i0, i1; };

// window coordinates (xy) and clip z of world point v under clip matrix M (hs: half the layer's size), one
// expression for sp_project and sp_reaches
vec3 sp_window(mat4 M, vec3 v, vec2 hs) { vec4 c = M * vec4(v, 1.0); return vec3(c.xy * hs + hs, c.z); }

bool sp_project(uint k, vec3 v0, vec3 v1, vec3 v2, out SpPair p) {
    mat4 M = ls_layers[k].clip;
    vec2 hs = vec2(ls_size) * 0.5;
    vec3 c0 = sp_window(M, v0, hs), c1 = sp_window(M, v1, hs), c2 = sp_window(M, v2, hs);
    p.w0 = c0.xy; p.w1 = c1.xy; p.w2 = c2.xy;
    p.z0 = c0.z; p.z1 = c1.z; p.z2 = c2.z;
    vec2 lo = min(p.w0, min(p.w1, p.w2)), hi = max(p.w0, max(p.w1, p.w2));
    if (!(all(greaterThanEqual(hi, vec2(0.0))) && all(lessThanEqual(lo, vec2(ls_size))))) return false;
    const float S = float(SP_ONE);
    p.f0 = ivec2(roundEven(p.w0 * S)); p.f1 = ivec2(roundEven(p.w1 * S)); p.f2 = ivec2(roundEven(p.w2 * S));
    ivec2 a = p.f1 - p.f0, b = p.f2 - p.f0;
    p.area = a.x * b.y - a.y * b.x;
    if (p.area == 0) return false;
    sp_texel_box(min(p.f0, min(p.f1, p.f2)), max(p.f0, max(p.f1, p.f2)), ls_size, p.i0, p.i1);
    return all(lessThanEqual(p.i0, p.i1));
}

#if SPLAT_QUEUE
// layer k's window row a (0: x, 1: y): sp_window's M and viewport in one vec4, x = dot(row.xyz, v) + row.w
vec4 sp_win_row(uint k, int a) {
    mat4 M = ls_layers[min(k, n_layers - 1u)].clip;
    float h = float(ls_size[a]) * 0.5;
    return vec4(M[0][a], M[1][a], M[2][a], M[3][a]) * h + vec4(0.0, 0.0, 0.0, h);
}
// the margin of a row's test: two sub-pixel steps (the snap moves a vertex by half of one) and a bound on the float
// rounding between this row's form and sp_window's, which grows with the terms' size (vertices far from the
// origin): 2^-19 of their largest sum, against a dozen roundings of 2^-24 each (sp_win_fold's offsets included)
float sp_win_margin(vec4 row) {
    return 2.0 / float(SP_ONE) + (dot(abs(row.xyz), sp_extent) + abs(row.w)) * (1.0 / 524288.0);
}
// a row with its margin folded in for sp_reaches: (row.xyz, the high side's offset row.w + margin - 1/2), and in lo
// the low side's offset row.w - margin - 1/2 (texel centres at integers + 1/2)
vec4 sp_win_fold(vec4 row, out float lo) {
    float m = sp_win_margin(row);
    lo = row.w - (m + 0.5);
    return vec4(row.xyz, row.w + (m - 0.5));
}
// the folded rows of the batch's first SPLAT_WIN_N layers (all but in batches too large for shared memory) and their
// low offsets, set up once per workgroup for sp_reaches
shared vec4 sp_win[2 * SPLAT_WIN_N];
shared float sp_win_lo[2 * SPLAT_WIN_N];
void sp_win_load(uint k0) {
    for (uint i = gl_LocalInvocationID.x; i < uint(2 * SPLAT_WIN_N); i += uint(SPLAT_GROUP)) {
        float lo;
        sp_win[i] = sp_win_fold(sp_win_row(k0 + (i >> 1), int(i & 1u)), lo);
        sp_win_lo[i] = lo;
    }
    barrier();
}

// whether the pair (triangle, layer k0 + kk) may reach a texel centre: its window box, widened by the row's
// margin, holds one (an integer n + 1/2 with lo - m <= n + 1/2 <= hi + m: floor(hi + m - 1/2) >= lo - m - 1/2, the
// offsets folded into the rows). SPLAT_QUEUE's first phase: no fixed point and no clamp to the layer for the pairs
// it rejects (most); sp_project decides the others exactly.
bool sp_reaches(uint k0, uint kk, vec3 v0, vec3 v1, vec3 v2) {
    vec4 rx, ry;
    vec2 lo_off;
#if SPLAT_WIN_N < SPLAT_BATCH
    if (kk >= uint(SPLAT_WIN_N)) {   // every invocation
        rx = sp_win_fold(sp_win_row(k0 + kk, 0), lo_off.x);
        ry = sp_win_fold(sp_win_row(k0 + kk, 1), lo_off.y);
    } else
#endif
    { rx = sp_win[2u * kk]; ry = sp_win[2u * kk + 1u]; lo_off = vec2(sp_win_lo[2u * kk], sp_win_lo[2u * kk + 1u]); }
    vec3 x = vec3(dot(rx.xyz, v0), dot(rx.xyz, v1), dot(rx.xyz, v2));
    vec3 y = vec3(dot(ry.xyz, v0), dot(ry.xyz, v1), dot(ry.xyz, v2));
    vec2 lo = vec2(min(x.x, min(x.y, x.z)), min(y.x, min(y.y, y.z))) + lo_off;
    vec2 hi = vec2(max(x.x, max(x.y, x.z)), max(y.x, max(y.y, y.z))) + vec2(rx.w, ry.w);
    return all(greaterThanEqual(floor(hi), lo));
}
#endif

#if SPLAT_QUEUE
// the fragments of a workgroup's queued pairs, stored together once they are all found (so that a warp's stores
// are not spread over its lanes' unequal boxes): (list, depth bits), and the triangle for a payload; past
// SP_FRAG_N, stored at once
#if LS_PAYLOAD > 0
#define SP_FRAG uvec3
#define SP_FRAG_N (SPLAT_GROUP * 2)
#define SP_FRAG_OF(LIST, DEPTH, T) uvec3(LIST, floatBitsToUint(DEPTH), T)
#define SP_FRAG_STORE(F) ls_store(F.x, uintBitsToFloat(F.y), sp_normal(F.z), sp_material(F.z))
#else
#define SP_FRAG uvec2
#define SP_FRAG_N (SPLAT_GROUP * 4)
#define SP_FRAG_OF(LIST, DEPTH, T) uvec2(LIST, floatBitsToUint(DEPTH))
#define SP_FRAG_STORE(F) ls_store(F.x, uintBitsToFloat(F.y), vec3(0.0), 0u)   // ignored without a payload
#endif
shared SP_FRAG sp_frag[SP_FRAG_N];
shared uint sp_frags;
#endif

void sp_store(uint t, uint list, float depth, vec3 normal, uint material) {
#if SPLAT_QUEUE
    uint slot = atomicAdd(sp_frags, 1u);
    if (slot < uint(SP_FRAG_N)) { sp_frag[slot] = SP_FRAG_OF(list, depth, t); return; }
#endif
    ls_store(list, depth, normal, material);
}

void sp_layer(uint t, uint k, vec3 v0, vec3 v1, vec3 v2, vec3 normal, uint material) {
    SpPair p;
    if (!sp_project(k, v0, v1, v2, p)) return;
    bool cw = p.area < 0;
    SpTri tri = sp_ccw(p.f0, p.f1, p.f2, cw);
    SpPlanes pl = sp_planes(k, cw, tri.f0, tri.f1, tri.f2, p.w0, p.w1, p.w2, p.z0, p.z1, p.z2, v0, v1, v2);
    for (int y = p.i0.y; y <= p.i1.y; ++y) {
        for (int x = p.i0.x; x <= p.i1.x; ++x) {
            if (!sp_covers(tri, ivec2(x, y))) continue;
            vec2 q = vec2(x, y) + 0.5 - pl.w0;
            if (abs(pl.z0 + dot(pl.dz, q)) > 1.0) continue;
            sp_store(t, ls_list(k, ivec2(x, y), ls_size), pl.d0 + dot(pl.dd, q), normal, material);
        }
    }
}

vec3 sp_vertex(uint t, uint j) { return sp_pos[3u * t + j].xyz; }
vec3 sp_normal(uint t) { return vec3(sp_vtx[21u * t + 3u], sp_vtx[21u * t + 4u], sp_vtx[21u * t + 5u]); }
uint sp_material(uint t) { return uint(sp_vtx[21u * t + 6u] + 0.5); }

// whether triangle t is left to the long triangles' pass (longer than splat_max in some layer, or not finite);
// the invocation of the first layer batch appends it to sp_large
bool sp_long(uint t, vec3 v0, vec3 v1, vec3 v2) {
    float e = max(max(distance(v0, v1), distance(v1, v2)), distance(v2, v0));
    if (e * splat_scale <= splat_max) return false;
    if (gl_WorkGroupID.y == 0u) {
        uint i = atomicAdd(sp_cmd[5u * sp_parity], 3u);
        sp_large[i] = 3u * t;
        sp_large[i + 1u] = 3u * t + 1u;
        sp_large[i + 2u] = 3u * t + 2u;
    }
    return true;
}

// the counts the next pass starts from, zeroed by the first invocation: the other parity's long triangles and, with
// SP_ZERO_SORT, the tiles' list of lists to sort (their readers of the last pass have completed)
void sp_begin() {
    if (gl_GlobalInvocationID.x != 0u || gl_GlobalInvocationID.y != 0u) return;
    sp_cmd[5u * (1u - sp_parity)] = 0u;
#if defined(SP_ZERO_SORT)
    sp_sort_n = 0u;
#endif
}

#if SPLAT_QUEUE
// the pairs of this workgroup's triangles whose box may hold a texel centre: triangle (low 16 bits, within the
// workgroup) and layer (high 16 bits, within the batch); a pair beyond SP_QUEUE_N is rasterized at once
#define SP_QUEUE_N (SPLAT_GROUP * 6)
shared uint sp_queue[SP_QUEUE_N];
shared uint sp_queued;

void main() {
    sp_begin();
    uint k0 = gl_WorkGroupID.y * uint(SPLAT_BATCH);
    uint k1 = min(k0 + uint(SPLAT_BATCH), n_layers);
    uint lid = gl_LocalInvocationID.x;
    uint stride = gl_NumWorkGroups.x * uint(SPLAT_GROUP);
    sp_win_load(k0);
    for (uint base = gl_WorkGroupID.x * uint(SPLAT_GROUP); base < n_triangles; base += stride) {
        if (lid == 0u) { sp_queued = 0u; sp_frags = 0u; }
        barrier();
        uint t = base + lid;
        if (t < n_triangles) {
            vec3 v0 = sp_vertex(t, 0u), v1 = sp_vertex(t, 1u), v2 = sp_vertex(t, 2u);
            if (!sp_long(t, v0, v1, v2)) {
                for (uint k = k0; k < k1; ++k) {
                    if (!sp_reaches(k0, k - k0, v0, v1, v2)) continue;
                    uint slot = atomicAdd(sp_queued, 1u);
                    if (slot < uint(SP_QUEUE_N)) sp_queue[slot] = lid | ((k - k0) << 16);
                    else sp_layer(t, k, v0, v1, v2, sp_normal(t), sp_material(t));
                }
            }
        }
        barrier();
        uint m = min(sp_queued, uint(SP_QUEUE_N));
        for (uint e = lid; e < m; e += uint(SPLAT_GROUP)) {   // the queued pairs by consecutive invocations
            uint q = sp_queue[e], tq = base + (q & 0xFFFFu);
            sp_layer(tq, k0 + (q >> 16), sp_vertex(tq, 0u), sp_vertex(tq, 1u), sp_vertex(tq, 2u), sp_normal(tq),
                     sp_material(tq));
        }
        barrier();
        uint nf = min(sp_frags, uint(SP_FRAG_N));
        for (uint e = lid; e < nf; e += uint(SPLAT_GROUP)) {   // their fragments, by consecutive invocations
            SP_FRAG f = sp_frag[e];
            SP_FRAG_STORE(f);
        }
        barrier();
    }
}
#else
void main() {
    sp_begin();
    uint k0 = gl_WorkGroupID.y * uint(SPLAT_BATCH);
    uint k1 = min(k0 + uint(SPLAT_BATCH), n_layers);
    uint stride = gl_NumWorkGroups.x * uint(SPLAT_GROUP);
    for (uint t = gl_GlobalInvocationID.x; t < n_triangles; t += stride) {
        vec3 v0 = sp_vertex(t, 0u), v1 = sp_vertex(t, 1u), v2 = sp_vertex(t, 2u);
        if (sp_long(t, v0, v1, v2)) continue;
        vec3 normal = sp_normal(t);
        uint material = sp_material(t);
        for (uint k = k0; k < k1; ++k) sp_layer(t, k, v0, v1, v2, normal, material);
    }
}
#endif
