// Tracing rays through orthographic layered depth maps (aalund2015 §3.1), over the layered-structure
// interface (layered/layered.glsl): the same code reads linked lists and linearised arrays.
//
// Map k looks along its axis v_k; (u_k, w_k, v_k) is a right-handed orthonormal basis; the map covers the
// scene's bounding sphere (centre ol_centre, radius ol_radius): texel coordinates are
// ((dot(p - c, u), dot(p - c, w)) / radius * 0.5 + 0.5) * size, and the stored depth of a fragment is
// dot(p - c, v). Lists are sorted by ascending depth, so along +v the first hit is the first entry
// beyond x and along -v it is the last entry before x: one map answers both directions.
//
// Self-intersection ("receiver-plane" test): x's own surface is in the list, at the texel centre q,
// not at x. For a locally planar surface with normal n through x, the column through q crosses that
// plane at ray distance s = -dot(n, q - x) / dot(n, d) (d = the ray direction, dot(n, d) > 0); entries
// with t <= s lie on or below x's tangent plane, where no ray leaving x can hit. Entries with
// t <= s + bias are skipped; bias (world units) absorbs curvature and float error.
// Concave creases: when s < 0 (the column passes x's tangent plane behind x), an entry with
// max(s, -ldm_crease) + bias < t <= 0 is geometry *above* the tangent plane, within half a texel of it and
// at most ldm_crease behind x — typically the other wall of a crease that the texel-centre column meets
// behind x. It is a hit at distance 0, not skipped: skipping it let rays escape through the adjacent
// wall (bright lines along creases). ldm_crease = 0 is the plain rule (skip everything up to
// max(s, 0) + bias); larger windows also catch small geometry just behind x (docs/reference/rays.md).
//
// Walk modes (trace.walk, ldbench/methods/ldm/__init__.py): by default the walk stops at x's depth, as soon as
// the answer is known (aalund2015 §4.1: "the search can be terminated as soon as a geometric intersection
// is found since the lists are pre-sorted"). LDM_FULL_WALK walks the whole list and keeps the nearest
// entry beyond the threshold, as an unsorted list needs: on sorted lists the answer is the same.
// Query modes (trace.query): by default a map answers both +v and -v (§3.1, the two-way query);
// LDM_ONE_WAY: one-directional maps (the adapter builds 2N, along +v_i and -v_i), so ldm_find_map chooses
// the nearest axis with sigma = +1 only, from its own full-cube table (LDM_LUT) or a scan (the AO pass skips
// the maps facing away from the normal: ao.glsl).
#ifndef LDBENCH_LDM_TRACE_GLSL
#define LDBENCH_LDM_TRACE_GLSL
#include "layered/layered.glsl"
#include "layered/ortho_layers.glsl"

uniform float ldm_crease;  // world units (0 = no crease rule)
#define LDM_FAR 3.0e38
#ifndef LDM_UNROLL
#define LDM_UNROLL 4
#endif

// One map query before its walk: x's list in map k, x's depth zx in it and the skip threshold thr.
struct LdmQuery { uint list; float zx; float thr; };

LdmQuery ldm_query(uint k, float sigma, vec3 x, vec3 n, float bias) {
    vec3 u = ol_axes[k].u.xyz, w = ol_axes[k].w.xyz, v = ol_axes[k].v.xyz;
    ivec2 px;
    vec2 delta;  // x -> texel centre, (u, w)
    LdmQuery q;
    q.zx = ol_locate(k, x, px, delta);
    float cos_t = sigma * dot(n, v);
    float s_self = -(delta.x * dot(n, u) + delta.y * dot(n, w)) / max(cos_t, 1e-8);
    q.thr = max(s_self, -ldm_crease) + bias;
    q.list = ls_list(k, px, ol_size);
    return q;
}

// The walk of a query from the list's first node (ls_first(q.list), which a caller may have loaded early):
// the hit distance t > 0 along sigma * v_k, or -1.0 when nothing lies beyond x on that side. Walks are
// bounded (ls_bound).
float ldm_walk(LdmQuery q, float sigma, uint first) {
#if defined(LDM_FULL_WALK)
    uint bound = ls_bound(), steps = 0u;
    float nearest = LDM_FAR;
    for (uint i = first; i != LS_END && steps < bound; i = ls_next(q.list, i), ++steps) {
        float t = sigma > 0.0 ? ls_depth(i) - q.zx : q.zx - ls_depth(i);
        if (t > q.thr) nearest = min(nearest, t);
    }
    return nearest < LDM_FAR ? max(nearest, 0.0) : -1.0;
#elif LS_LAYOUT == 2
    // linear arrays: the next LDM_UNROLL depths of a list are loaded together, not one dependent load after
    // another; the same entries are compared in the same order as the walk below
    if (first == LS_END) return -1.0;
    uint e = la_end(q.list);
    float best = -1.0;
    for (uint i = first; i < e; i += uint(LDM_UNROLL)) {
        float z[LDM_UNROLL];
        for (int j = 0; j < LDM_UNROLL; ++j) z[j] = i + uint(j) < e ? la_depth[i + uint(j)] : 0.0;
        for (int j = 0; j < LDM_UNROLL; ++j) {
            if (i + uint(j) >= e) break;
            float t = sigma > 0.0 ? z[j] - q.zx : q.zx - z[j];
            if (sigma > 0.0) {
                if (t > q.thr) return max(t, 0.0);
            } else {
                if (t <= q.thr) return best;
                best = max(t, 0.0);
            }
        }
    }
    return best;
#else
    // ls_step: a node's depth and link in one load
    uint bound = ls_bound(), steps = 0u;
    if (sigma > 0.0) {
        for (uint i = first; i != LS_END && steps < bound; ++steps) {
            float t = ls_step(q.list, i) - q.zx;
            if (t > q.thr) return max(t, 0.0);
        }
        return -1.0;
    }
    float best = -1.0;
    for (uint i = first; i != LS_END && steps < bound; ++steps) {
        float t = q.zx - ls_step(q.list, i);
        if (t <= q.thr) break;
        best = max(t, 0.0);
    }
    return best;
#endif
}

// Hit distance t > 0 along d = sigma * v_k from x (n: surface normal at x, dot(n, d) > 0), or -1.0
// when the ray leaves the scene (nothing stored beyond x on that side).
float ldm_trace(uint k, float sigma, vec3 x, vec3 n, float bias) {
    LdmQuery q = ldm_query(k, sigma, x, n, bias);
    return ldm_walk(q, sigma, ls_first(q.list));
}

// The map whose axis is closest to direction d (for arbitrary directions); sigma = which side.
// LDM_LUT: the candidates of d's cell of a half cube (ldbench/methods/directions.py nearest_axis_table,
// ol_table_row); otherwise a scan of all N axes.
#if defined(LDM_LUT)
layout(std430, binding = B_LDM_LUT) readonly buffer LdmLut { uvec4 ldm_lut[]; };
uniform int ldm_lut_res;
// The one-way table's row of d (ldbench/methods/ldm/__init__.py one_way_axis_table): a full cube, 12 candidates
// (3 uvec4) per cell; face 2a + (d_a < 0) of the dominant axis a, cell of (d_{a+1}, d_{a+2}) / |d_a|.
int ldm_one_way_row(vec3 d, int res) {
    vec3 ad = abs(d);
    int a = (ad.x >= ad.y && ad.x >= ad.z) ? 0 : (ad.y >= ad.z ? 1 : 2);
    vec2 uv = vec2(d[(a + 1) % 3], d[(a + 2) % 3]) / ad[a];
    ivec2 ij = clamp(ivec2(floor((uv + 1.0) * 0.5 * float(res))), ivec2(0), ivec2(res - 1));
    return ((2 * a + (d[a] < 0.0 ? 1 : 0)) * res + ij.x) * res + ij.y;
}
#endif
uint ldm_find_map(vec3 d, uint n_maps, out float sigma) {
    uint best = 0u;
    float bc = -1.0;
    sigma = 1.0;
#if defined(LDM_ONE_WAY)  // the nearest of the N directions +v_k (largest signed d.v)
#if defined(LDM_LUT)
    int row = ldm_one_way_row(d, ldm_lut_res);
    for (int q = 0; q < 3; ++q) {
        uvec4 cand = ldm_lut[3 * row + q];
        for (int s = 0; s < 4; ++s) {
            uint k = cand[s];
            if (k == 0xFFFFFFFFu) return best;
            float c = dot(d, ol_axes[k].v.xyz);
            if (c > bc) { bc = c; best = k; }
        }
    }
#else
    for (uint k = 0u; k < n_maps; ++k) {
        float c = dot(d, ol_axes[k].v.xyz);
        if (c > bc) { bc = c; best = k; }
    }
#endif
    return best;
#endif
#if defined(LDM_LUT)
    uvec4 cand = ldm_lut[ol_table_row(d, ldm_lut_res)];
    for (int s = 0; s < 4; ++s) {
        uint k = cand[s];
        if (k == 0xFFFFFFFFu) break;
        float c = dot(d, ol_axes[k].v.xyz);
        if (abs(c) > bc) { bc = abs(c); best = k; sigma = c >= 0.0 ? 1.0 : -1.0; }
    }
#else
    for (uint k = 0u; k < n_maps; ++k) {
        float c = dot(d, ol_axes[k].v.xyz);
        if (abs(c) > bc) { bc = abs(c); best = k; sigma = c >= 0.0 ? 1.0 : -1.0; }
    }
#endif
    return best;
}
#endif
