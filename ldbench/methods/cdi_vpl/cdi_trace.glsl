// Rays through a compound deep image (archer2019 §3.2): the single-pixel lookup. A ray is answered by the
// deep image whose direction is nearest to it (|d · v_k| largest; sigma = the side), in the one pixel that
// contains its origin x: the list is stepped from the near end until a fragment beyond x is met ("stepped in
// reverse order for rays in the matching opposite direction"). The distance is measured along sigma · v_k,
// the paper's approximation of the ray ("the difference in depth between the fragment and the light").
//
// Deep image k: orthographic along v_k over the bounding sphere (ol_centre, ol_radius), texel
// ((dot(p - c, u), dot(p - c, w)) / radius · ½ + ½) · size, stored depth dot(p - c, v) (ldbench/methods/ldm
// ldm_layers). Read through the layered-structure interface (layered/layered.glsl); linear arrays are walked
// backwards for sigma < 0.
//
// The search (trace.search): the paper's "linear stepwise search", or a binary search of the sorted array
// ("a binary search was found to be slower", §3.2), which must find the same entry.
//
// Self-intersection (ours; the paper does not say): x's own surface is in x's list, at the depth where its
// tangent plane (normal n, dot(n, sigma v) > 0) crosses the column of the fragment's sample: at the texel
// centre, t_c = -(δ_u n·u + δ_w n·w) / cos, for a build that samples texel centres (brute force); anywhere
// in the texel for the one-pass build (cdi_spread = 1), i.e. up to ½ texel (|n·u| + |n·w|) / cos above
// t_c. Entries up to that bound plus cdi_bias (world units: curvature, float error) are skipped; the first
// beyond it is the hit (at max(t, 0): as in the LDM tracer, a crease entry above the plane but behind x
// is a hit at 0). The skipped band also hides a wall meeting x's surface at a crease within it: a ray
// from a VPL in a corner can miss the wall beside it (a stored normal per fragment to tell the two apart
// was tried and measured worse: self hits on curved surfaces, docs/reference/methods/cdi_vpl.md).
#ifndef LDBENCH_CDI_TRACE_GLSL
#define LDBENCH_CDI_TRACE_GLSL
#include "layered/layered.glsl"
#include "layered/ortho_layers.glsl"

uniform uint cdi_dirs;
uniform float cdi_bias;
uniform float cdi_spread;

// The deep image whose direction is nearest to d (largest |d · v_k|); sigma = +1 along v, -1 against it.
//   CDI_GRID_LOOKUP   stacks × slices directions (cdi_grid = (stacks, slices)): the candidates are the 3 × 3
//                     cells of the (θ, φ) grid around d flipped to the upper hemisphere, and the 2 × 3 cells
//                     of the two rings above the equator around φ + π (d near the equator: its nearest axis
//                     can be on the other side); equal to the full scan on 2·10⁶ random directions for every
//                     shape of 1 to 4096 directions tried (tests/test_cdi_vpl.py checks it on the GPU)
//   CDI_TABLE_LOOKUP  any set: ≤ 4 candidates per cell of a half cube (ldbench/methods/directions.py nearest_axis_table)
//   otherwise         a scan of all cdi_dirs directions
#if defined(CDI_GRID_LOOKUP)
uniform ivec2 cdi_grid;
#elif defined(CDI_TABLE_LOOKUP)
layout(std430, binding = B_CDI_LUT) readonly buffer CdiLut { uvec4 cdi_lut[]; };
uniform int cdi_lut_res;
#endif
void cdi_try(uint k, vec3 d, inout float bc, inout uint best, inout float sigma) {
    float c = dot(d, ol_axes[k].v.xyz);
    if (abs(c) > bc) { bc = abs(c); best = k; sigma = c >= 0.0 ? 1.0 : -1.0; }
}
uint cdi_nearest(vec3 d, out float sigma) {
    uint best = 0u;
    float bc = -1.0;
    sigma = 1.0;
#if defined(CDI_GRID_LOOKUP)
    const float TWO_PI = 6.28318530717958648;
    int S = cdi_grid.x, L = cdi_grid.y;
    vec3 e = d.y < 0.0 ? -d : d;
    float th = acos(clamp(e.y, -1.0, 1.0));
    float ph = atan(e.z, e.x);
    if (ph < 0.0) ph += TWO_PI;
    int i = clamp(int(floor(th / (0.25 * TWO_PI) * float(S))), 0, S - 1);
    int j = int(floor(ph / TWO_PI * float(L))) % L;
    float po = ph + 0.5 * TWO_PI;
    if (po >= TWO_PI) po -= TWO_PI;
    int jo = int(floor(po / TWO_PI * float(L))) % L;
    for (int di = -1; di <= 1; ++di) {
        int ii = i + di;
        if (ii < 0 || ii >= S) continue;
        for (int dj = -1; dj <= 1; ++dj) cdi_try(uint(ii * L + (j + dj + L) % L), d, bc, best, sigma);
    }
    for (int di = 0; di <= 1; ++di) {
        int ii = S - 1 - di;
        if (ii < 0) continue;
        for (int dj = -1; dj <= 1; ++dj) cdi_try(uint(ii * L + (jo + dj + L) % L), d, bc, best, sigma);
    }
#elif defined(CDI_TABLE_LOOKUP)
    uvec4 cand = cdi_lut[ol_table_row(d, cdi_lut_res)];
    for (int s = 0; s < 4; ++s) {
        if (cand[s] == 0xFFFFFFFFu) break;
        cdi_try(cand[s], d, bc, best, sigma);
    }
#else
    for (uint k = 0u; k < cdi_dirs; ++k) cdi_try(k, d, bc, best, sigma);
#endif
    return best;
}

// Distance t >= 0 along sigma · v_k from x to the first stored surface beyond x, or -1.0 (none).
float cdi_trace(uint k, float sigma, vec3 x, vec3 n) {
    vec3 u = ol_axes[k].u.xyz, w = ol_axes[k].w.xyz, v = ol_axes[k].v.xyz;
    float texel = 2.0 * ol_radius / float(ol_size.x);
    ivec2 px;
    vec2 delta;
    float zx = ol_locate(k, x, px, delta);
    float nu = dot(n, u), nw = dot(n, w);
    float cos_t = max(sigma * dot(n, v), 1e-3);
    float thr = (-(delta.x * nu + delta.y * nw) + cdi_spread * 0.5 * texel * (abs(nu) + abs(nw))) / cos_t
                + cdi_bias;
    uint list = ls_list(k, px, ol_size);
#if defined(CDI_BINARY_SEARCH)
    // trace.search = binary (linear arrays only): the same answer as the walks below, since the list ascends
    // in depth and the tests are monotone in it. sigma > 0: the first entry with t > thr (lower bound);
    // sigma < 0: the last entry with zx - depth > thr.
    uint b = la_begin(list), e = la_end(list), lo = b, hi = e;
    if (sigma > 0.0) {
        while (lo < hi) {
            uint mid = (lo + hi) >> 1;
            if (la_depth[mid] - zx > thr) hi = mid; else lo = mid + 1u;
        }
        return lo < e ? max(la_depth[lo] - zx, 0.0) : -1.0;
    }
    while (lo < hi) {
        uint mid = (lo + hi) >> 1;
        if (zx - la_depth[mid] > thr) lo = mid + 1u; else hi = mid;
    }
    return lo > b ? max(zx - la_depth[lo - 1u], 0.0) : -1.0;
#else
    if (sigma > 0.0) {
        uint bound = ls_bound(), steps = 0u;
        for (uint i = ls_first(list); i != LS_END && steps < bound; i = ls_next(list, i), ++steps) {
            float t = ls_depth(i) - zx;
            if (t > thr) return max(t, 0.0);
        }
        return -1.0;
    }
#if LS_LAYOUT == 2
    uint b = la_begin(list);
    for (uint i = la_end(list); i > b; --i) {
        float t = zx - la_depth[i - 1u];
        if (t > thr) return max(t, 0.0);
    }
    return -1.0;
#else
    float best = -1.0;
    uint bound = ls_bound(), steps = 0u;
    for (uint i = ls_first(list); i != LS_END && steps < bound; i = ls_next(list, i), ++steps) {
        float t = zx - ls_depth(i);
        if (t <= thr) break;
        best = max(t, 0.0);
    }
    return best;
#endif
#endif
}
#endif
