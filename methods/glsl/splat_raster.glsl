// Compute-shader rasterizer of small triangles into a layered structure (methods/structures/splat.py,
// build = "splat"): one invocation per (triangle, batch of SPLAT_BATCH layers), every covered texel
// stored with the same ls_store as the hardware raster (layered_store.glsl).
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
// layer), exceeds splat_max texels is left to a second pass (splat_tiles.glsl, or the hardware): the
// invocation of its first layer batch appends its vertex indices to sp_large, the index list of both
// (sp_cmd is the hardware's indirect draw command; sp_cmd[0] counts the indices). splat_max <= 64 keeps
// every edge function within int32 (coordinate differences < 65 * 256 = 2^14.1, products < 2^29.1).
//
// Defines: as layered_build.glsl (LS_LAYOUT, LS_PASS_COUNT, LS_EMIT, LL_SORTED, LS_PAYLOAD / LS_PL_*,
// LL_AGGREGATE), SPLAT_BATCH (layers per invocation), SPLAT_GROUP (invocations per workgroup),
// LS_SUBPIXEL_BITS, SPLAT_TOP/BOTTOM/LEFT/RIGHT, SPLAT_SNAPPED_PLANE (0 or 1).
#include "layered_write.glsl"

layout(local_size_x = SPLAT_GROUP) in;
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
#include "splat_planes.glsl"

void sp_layer(uint k, vec3 v0, vec3 v1, vec3 v2, vec3 normal, uint material) {
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
    bool cw = area < 0;
    SpTri tri = sp_ccw(f0, f1, f2, cw);
    SpPlanes pl = sp_planes(k, cw, tri.f0, tri.f1, tri.f2, w0, w1, w2, c0.z, c1.z, c2.z, v0, v1, v2);
    for (int y = i0.y; y <= i1.y; ++y) {
        for (int x = i0.x; x <= i1.x; ++x) {
            if (!sp_covers(tri, ivec2(x, y))) continue;
            vec2 q = vec2(x, y) + 0.5 - pl.w0;
            if (abs(pl.z0 + dot(pl.dz, q)) > 1.0) continue;
            ls_store(ls_list(k, ivec2(x, y), ls_size), pl.d0 + dot(pl.dd, q), normal, material);
        }
    }
}

void main() {
    uint k0 = gl_WorkGroupID.y * uint(SPLAT_BATCH);
    uint k1 = min(k0 + uint(SPLAT_BATCH), n_layers);
    uint stride = gl_NumWorkGroups.x * uint(SPLAT_GROUP);
    for (uint t = gl_GlobalInvocationID.x; t < n_triangles; t += stride) {
        uint o = 21u * t;
        vec3 v0 = vec3(sp_vtx[o], sp_vtx[o + 1u], sp_vtx[o + 2u]);
        vec3 v1 = vec3(sp_vtx[o + 7u], sp_vtx[o + 8u], sp_vtx[o + 9u]);
        vec3 v2 = vec3(sp_vtx[o + 14u], sp_vtx[o + 15u], sp_vtx[o + 16u]);
        float e = max(max(distance(v0, v1), distance(v1, v2)), distance(v2, v0));
        if (!(e * splat_scale <= splat_max)) {   // large (or not finite): the second pass's
            if (gl_WorkGroupID.y == 0u) {
                uint i = atomicAdd(sp_cmd[0], 3u);
                sp_large[i] = 3u * t;
                sp_large[i + 1u] = 3u * t + 1u;
                sp_large[i + 2u] = 3u * t + 2u;
            }
            continue;
        }
        vec3 normal = vec3(sp_vtx[o + 3u], sp_vtx[o + 4u], sp_vtx[o + 5u]);
        uint material = uint(sp_vtx[o + 6u] + 0.5);
        for (uint k = k0; k < k1; ++k) sp_layer(k, v0, v1, v2, normal, material);
    }
}
