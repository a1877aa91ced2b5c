// Compute-shader rasterizer of small triangles into a layered structure (methods/structures/splat.py,
// build = "splat"): one invocation per (triangle, batch of SPLAT_BATCH layers), every covered texel
// stored with the same ls_store as the hardware raster (layered_store.glsl).
//
// Schedule (SPLAT_QUEUE): most (triangle, layer) pairs cover no texel centre and the rest only a few, so an
// invocation that looped over its own texel box would leave most lanes of its warp idle in the store
// loop, and their atomics would issue one lane at a time. Instead each invocation sets its pair up (the
// snapped triangle, its texel box, its depth and clip planes: a queue entry in shared memory) and appends
// the box's texels to the workgroup's candidate queue; once the queue holds a workgroup's worth, every
// invocation takes one candidate: the edge tests and the store run on full warps. Boxes of more than
// SPLAT_QUEUE_BOX texels are rasterized by their own invocation. SPLAT_QUEUE = 0: every box by its own
// invocation (the earlier schedule). Both store the same fragments.
//
// Coverage is the hardware's (gbuffer_fill_rule.glsl, shared with the compute G-buffer): window coordinates
// snapped to LS_SUBPIXEL_BITS of fixed point, samples at texel centres, exact integer edge functions, and
// the edge classes this GPU includes. Zero-area triangles (after snapping) cover nothing.
// Depth and clip z are the planes through the three vertices evaluated at the texel centre, as the
// hardware interpolates: through the snapped vertices with SPLAT_SNAPPED_PLANE (NVIDIA), else through the
// given ones (llvmpipe); a sliver's depths differ by up to ~1 % between the two. A sample outside the
// near/far planes (|z| > 1) is dropped as clipping would. Layers must be affine (w = 1, orthographic
// maps: checked on the host).
//
// Large triangles: one whose longest edge, times splat_scale (the most texels per world unit of any
// layer), exceeds splat_max texels is left to the hardware: the invocation of its first layer batch
// appends its vertex indices to sp_large, the index list of an instanced indirect draw (the draw command
// is sp_cmd; sp_cmd[0] counts the indices). splat_max <= 64 keeps every edge function within int32
// (coordinate differences < 65 * 256 = 2^14.1, products < 2^29.1).
//
// Defines: as layered_build.glsl (LS_LAYOUT, LS_PASS_COUNT, LS_EMIT, LL_SORTED, LS_PAYLOAD / LS_PL_*,
// LL_AGGREGATE), SPLAT_BATCH (layers per invocation), LS_SUBPIXEL_BITS, SPLAT_TOP/BOTTOM/LEFT/RIGHT,
// SPLAT_SNAPPED_PLANE (0 or 1), SPLAT_WG (invocations per workgroup), SPLAT_QUEUE (0 or 1), SPLAT_QUEUE_BOX.
#include "layered_write.glsl"

layout(local_size_x = SPLAT_WG) in;
// geometry.vertices (methods/gbuffer.py): per vertex position (3), face normal (3), material (1)
layout(std430, binding = B_SPLAT_VERTICES) readonly buffer SplatVertices { float sp_vtx[]; };
layout(std430, binding = B_SPLAT_LARGE) buffer SplatLarge { uint sp_cmd[8]; uint sp_large[]; };
uniform ivec2 ls_size;       // W, H of one layer
uniform uint ls_capacity;    // nodes / fragments the structure holds
uniform uint n_triangles;
uniform uint n_layers;
uniform float splat_scale;   // texels per world unit, the largest of any layer
uniform float splat_max;     // longest edge (texels) rasterized here
#include "layered_store.glsl"
#include "gbuffer_fill_rule.glsl"

// One (triangle, layer) pair that covers a texel box: counter-clockwise fixed-point vertices, the box
// (origin and width), the window position of vertex 0 and the depth and clip-z planes from it.
struct SpEntry { ivec2 f0, f1, f2, i0; vec2 w0, dd, dz; float d0, z0; uint width, k, t; };
#if SPLAT_QUEUE
const uint SQ_CANDS = uint(SPLAT_WG) * uint(SPLAT_QUEUE_BOX + 1);   // pending < WG, plus one round's appends
#endif
// entries: < WG pending at a round's start (the flush rule), at most WG added per round
shared SpEntry sq_entry[2 * SPLAT_WG];
shared uint sq_n_entries;
#if SPLAT_QUEUE
shared uint sq_cand[SQ_CANDS];   // entry << 16 | texel index in its box
shared uint sq_n_cands;
#endif

// texel i (row-major in the box) of entry e: the edge tests, the near/far clip, the store
void sp_texel(uint e, uint i) {
    SpEntry q = sq_entry[e];
    int x = q.i0.x + int(i % q.width), y = q.i0.y + int(i / q.width);
    ivec2 e0 = q.f1 - q.f0, e1 = q.f2 - q.f1, e2 = q.f0 - q.f2;
    ivec2 p = ivec2(x, y) * SP_ONE + SP_HALF;
    if (sp_edge(e0, q.f0, p) < sp_bias(e0) || sp_edge(e1, q.f1, p) < sp_bias(e1) || sp_edge(e2, q.f2, p) < sp_bias(e2))
        return;
    vec2 r = vec2(x, y) + 0.5 - q.w0;
    if (abs(q.z0 + dot(q.dz, r)) > 1.0) return;
    uint o = 21u * q.t;
    vec3 normal = vec3(sp_vtx[o + 3u], sp_vtx[o + 4u], sp_vtx[o + 5u]);
    uint material = uint(sp_vtx[o + 6u] + 0.5);
    ls_store(ls_list(q.k, ivec2(x, y), ls_size), q.d0 + dot(q.dd, r), normal, material);
}

// set the pair (triangle t, layer k) up; queue its texels (or rasterize a large box here)
void sp_pair(uint t, uint k, vec3 v0, vec3 v1, vec3 v2) {
    mat4 M = ls_layers[k].clip;
    vec2 hs = vec2(ls_size) * 0.5;
    vec4 c0 = M * vec4(v0, 1.0), c1 = M * vec4(v1, 1.0), c2 = M * vec4(v2, 1.0);
    vec2 w0 = c0.xy * hs + hs, w1 = c1.xy * hs + hs, w2 = c2.xy * hs + hs;   // window coordinates
    vec2 lo = min(w0, min(w1, w2)), hi = max(w0, max(w1, w2));
    if (!(all(greaterThanEqual(hi, vec2(0.0))) && all(lessThanEqual(lo, vec2(ls_size))))) return;
    const float S = float(SP_ONE);
    ivec2 f0 = ivec2(roundEven(w0 * S)), f1 = ivec2(roundEven(w1 * S)), f2 = ivec2(roundEven(w2 * S));
    ivec2 a = f1 - f0, b = f2 - f0;
    int area = a.x * b.y - a.y * b.x;
    if (area == 0) return;
    ivec2 fmin = min(f0, min(f1, f2)), fmax = max(f0, max(f1, f2));
    ivec2 i0, i1;
    sp_texel_box(fmin, fmax, ls_size, i0, i1);
    if (any(greaterThan(i0, i1))) return;   // no texel centre in the box: most (triangle, layer) pairs
    if (area < 0) {   // counter-clockwise
        ivec2 ti = f1; f1 = f2; f2 = ti;
        vec2 tw = w1; w1 = w2; w2 = tw;
        vec4 tc = c1; c1 = c2; c2 = tc;
        vec3 tv = v1; v1 = v2; v2 = tv;
    }
#if SPLAT_SNAPPED_PLANE
    w0 = vec2(f0) / S; w1 = vec2(f1) / S; w2 = vec2(f2) / S;   // exact: |f| < 2^24
#endif
    vec4 row = ls_layers[k].depth_row;
    float d0 = dot(row, vec4(v0, 1.0)), d1 = dot(row, vec4(v1, 1.0)), d2 = dot(row, vec4(v2, 1.0));
    SpEntry q;
    q.f0 = f0; q.f1 = f1; q.f2 = f2; q.i0 = i0; q.w0 = w0;
    q.dd = sp_plane_gradient(w0, w1, w2, d0, d1, d2);
    q.dz = sp_plane_gradient(w0, w1, w2, c0.z, c1.z, c2.z);
    q.d0 = d0; q.z0 = c0.z;
    q.width = uint(i1.x - i0.x + 1); q.k = k; q.t = t;
    uint n = q.width * uint(i1.y - i0.y + 1);
    uint e = atomicAdd(sq_n_entries, 1u);
    sq_entry[e] = q;
#if SPLAT_QUEUE
    if (n <= uint(SPLAT_QUEUE_BOX)) {
        uint base = atomicAdd(sq_n_cands, n);
        for (uint i = 0u; i < n; ++i) sq_cand[base + i] = e << 16 | i;
        return;
    }
#endif
    for (uint i = 0u; i < n; ++i) sp_texel(e, i);
}

// after a round (every invocation): store the queued texels once a workgroup's worth is waiting (always
// when last), and free the entries; the decision is read by all before anyone appends again
void sp_round(bool last) {
    memoryBarrierShared();
    barrier();
    uint entries = sq_n_entries;
#if SPLAT_QUEUE
    uint cands = sq_n_cands;
#else
    uint cands = 0u;
#endif
    barrier();
    if (!(last || cands >= uint(SPLAT_WG) || entries >= uint(SPLAT_WG))) return;   // uniform
#if SPLAT_QUEUE
    for (uint j = gl_LocalInvocationID.x; j < cands; j += uint(SPLAT_WG)) {
        uint c = sq_cand[j];
        sp_texel(c >> 16, c & 0xFFFFu);
    }
#endif
    memoryBarrierShared();
    barrier();
    if (gl_LocalInvocationID.x == 0u) {
        sq_n_entries = 0u;
#if SPLAT_QUEUE
        sq_n_cands = 0u;
#endif
    }
    memoryBarrierShared();
    barrier();
}

void main() {
    if (gl_LocalInvocationID.x == 0u) {
        sq_n_entries = 0u;
#if SPLAT_QUEUE
        sq_n_cands = 0u;
#endif
    }
    memoryBarrierShared();
    barrier();
    uint k0 = gl_WorkGroupID.y * uint(SPLAT_BATCH);
    uint k1 = min(k0 + uint(SPLAT_BATCH), n_layers);
    uint stride = gl_NumWorkGroups.x * uint(SPLAT_WG);
    for (uint base = gl_WorkGroupID.x * uint(SPLAT_WG); base < n_triangles; base += stride) {   // uniform
        uint t = base + gl_LocalInvocationID.x;
        bool small = t < n_triangles;
        vec3 v0 = vec3(0.0), v1 = vec3(0.0), v2 = vec3(0.0);
        if (small) {
            uint o = 21u * t;
            v0 = vec3(sp_vtx[o], sp_vtx[o + 1u], sp_vtx[o + 2u]);
            v1 = vec3(sp_vtx[o + 7u], sp_vtx[o + 8u], sp_vtx[o + 9u]);
            v2 = vec3(sp_vtx[o + 14u], sp_vtx[o + 15u], sp_vtx[o + 16u]);
            float e = max(max(distance(v0, v1), distance(v1, v2)), distance(v2, v0));
            if (!(e * splat_scale <= splat_max)) {   // large (or not finite): the hardware's
                small = false;
                if (gl_WorkGroupID.y == 0u) {
                    uint i = atomicAdd(sp_cmd[0], 3u);
                    sp_large[i] = 3u * t;
                    sp_large[i + 1u] = 3u * t + 1u;
                    sp_large[i + 2u] = 3u * t + 2u;
                }
            }
        }
        for (uint k = k0; k < k1; ++k) {
            if (small) sp_pair(t, k, v0, v1, v2);
            sp_round(false);
        }
    }
    sp_round(true);
}
