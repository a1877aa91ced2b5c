// Pixel-crossing ray traversal of orthographic LDIs (niessner2010 §3.2), over the layered-structure
// interface (layered/layered.glsl, LS_LAYOUT 2: compacted per-texel lists sorted by depth).
//
// LDI k looks along v_k, (u_k, w_k, v_k) right-handed orthonormal; it covers the scene's bounding sphere
// (centre ol_centre, radius R) with ol_size² pixels of side 2R / ol_size; a fragment's stored depth is
// dot(p - c, v_k). One LDI answers rays along +v_k and -v_k (ldi_half = 1) or only +v_k.
//
// 1. LDI: the cube cell of d, in the cube's frame (ldbench/methods/directions.py cube_cell: the major axis, x
//    before y before z on ties; the square of the face that contains d).
// 2. Project the origin o: pixel coordinates f0 = ((dot(o - c, u), dot(o - c, w)) / R * 0.5 + 0.5) * res,
//    depth z0 = dot(o - c, v); along the ray f(t) = f0 + t g, z(t) = z0 + t dz.
// 3. Walk the pixels the 2D line crosses (Amanatides-Woo DDA; x steps first when both boundaries are
//    crossed at the same t), starting at o's pixel. In a pixel the ray spans t in [t_in, t_out], depths
//    z(t_in) .. z(t_out); a fragment of depth D is hit when D lies in that depth interval widened by
//    epsilon on both sides but clamped to [z(0), z(tmax)] (never behind the origin nor past tmax): the
//    epsilon tolerance that closes leaks through steep surfaces between pixel samples. The first such
//    fragment in ray order (smallest D for dz >= 0, largest for dz < 0) is the hit, at
//    t = clamp((D - z0) / dz, t_in, t_out).
//    Fragments on or below o's tangent plane (within bias: the fragment's point at the pixel centre,
//    q, has dot(n, q - o) <= bias) are skipped: a ray leaving o above its tangent plane cannot reach them,
//    and o's own surface is among them. (So is geometry meeting o's surface at an edge whose pixel-centre
//    sample lands below the plane: a ray grazing o's surface may pass under a wall standing on it within
//    about a pixel of the edge. Keeping differently oriented fragments there measured worse: docs/reference/methods/ldi.md.)
// 4. The walk ends at a hit, when the ray leaves the pixel grid or the bounding sphere or passes tmax, or
//    after max_crossings pixel crossings (0 = no limit but the grid's; the ray then counts as a miss,
//    `ended`). Whatever the float values (a NaN origin or tmax), it ends after at most size.x + size.y
//    crossings: each one moves one pixel along x or y, never back, so a ray that takes more has left the
//    grid already (it counts as `ended`, a miss).
#ifndef LDBENCH_LDI_TRACE_GLSL
#define LDBENCH_LDI_TRACE_GLSL
#include "layered/layered.glsl"
#include "layered/ortho_layers.glsl"

uniform int ldi_k;            // squares per cube-face edge: 6k² directions
uniform int ldi_half;         // 1: one LDI per pair of opposite directions
uniform float ldi_eps;        // world units
uniform float ldi_bias;       // world units
uniform uint ldi_max_cross;   // 0 = no limit but the grid's (size.x + size.y)
uniform mat3 ldi_to_cube;     // world -> the direction cube's frame (identity unless `rotated`)

const float LDI_INF = uintBitsToFloat(0x7f800000u);

struct LdiHit {
    float t;          // hit distance, or -1.0
    uint node;        // the fragment hit (payload), or LS_END
    uint crossings;   // pixel crossings walked
    uint ldi;         // the LDI that answered
    bool ended;       // stopped by max_crossings
    vec3 pos;         // the fragment's own point: its pixel centre at its depth (on the surface)
};

uint ldi_lookup(vec3 dw) {
    vec3 d = ldi_to_cube * dw;
    vec3 a = abs(d);
    int ax = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    float s = d[ax] >= 0.0 ? 1.0 : -1.0;
    vec3 dp = d * s;
    float m = dp[ax];
    float kf = float(ldi_k);
    int i = clamp(int(floor((dp[(ax + 1) % 3] / m + 1.0) * 0.5 * kf)), 0, ldi_k - 1);
    int j = clamp(int(floor((dp[(ax + 2) % 3] / m + 1.0) * 0.5 * kf)), 0, ldi_k - 1);
    uint cell = uint(i * ldi_k + j), kk = uint(ldi_k * ldi_k);
    if (ldi_half != 0) return uint(ax) * kk + cell;
    return uint(2 * ax + (s < 0.0 ? 1 : 0)) * kk + cell;
}

LdiHit ldi_trace(vec3 o, vec3 d, vec3 n, float tmax) {
    LdiHit h;
    h.t = -1.0; h.node = LS_END; h.crossings = 0u; h.ended = false;
    uint k = ldi_lookup(d);
    h.ldi = k;
    vec3 u = ol_axes[k].u.xyz, w = ol_axes[k].w.xyz, v = ol_axes[k].v.xyz;
    float R = ol_radius;
    float ppu = float(ol_size.x) / (2.0 * R);                   // pixels per world unit
    vec3 r = o - ol_centre;
    vec2 f = vec2(dot(r, u), dot(r, w)) * ppu + 0.5 * float(ol_size.x);
    float z0 = dot(r, v);
    vec2 g = vec2(dot(d, u), dot(d, w)) * ppu;               // pixels per unit of t
    float dz = dot(d, v);
    vec2 nuw = vec2(dot(n, u), dot(n, w)) / ppu;             // tangent-plane height per pixel of offset
    float nv = dot(n, v);
    float b = dot(r, d), c = dot(r, r) - R * R;
    float t_end = min(tmax, -b + sqrt(max(b * b - c, 0.0))); // bounding-sphere exit
    ivec2 size = ol_size;
    ivec2 px = clamp(ivec2(floor(f)), ivec2(0), size - 1);
    ivec2 stp = ivec2(g.x > 0.0 ? 1 : (g.x < 0.0 ? -1 : 0), g.y > 0.0 ? 1 : (g.y < 0.0 ? -1 : 0));
    vec2 tdelta = vec2(g.x != 0.0 ? 1.0 / abs(g.x) : LDI_INF, g.y != 0.0 ? 1.0 / abs(g.y) : LDI_INF);
    vec2 tnext = vec2(g.x > 0.0 ? (float(px.x + 1) - f.x) / g.x : (g.x < 0.0 ? (float(px.x) - f.x) / g.x : LDI_INF),
                      g.y > 0.0 ? (float(px.y + 1) - f.y) / g.y : (g.y < 0.0 ? (float(px.y) - f.y) / g.y : LDI_INF));
    float z_max = isinf(tmax) ? (dz >= 0.0 ? LDI_INF : -LDI_INF) : z0 + tmax * dz;  // depth at tmax
    float t_in = 0.0;
    uint bound = ls_bound();
    uint walk_max = uint(size.x + size.y);                   // the most crossings a walk can make
    while (h.crossings <= walk_max) {
        float t_out = min(min(tnext.x, tnext.y), t_end);
        float za = z0 + t_in * dz, zb = z0 + t_out * dz;
        float lo = dz >= 0.0 ? max(za - ldi_eps, z0) : max(zb - ldi_eps, z_max);   // never behind the
        float hi = dz >= 0.0 ? min(zb + ldi_eps, z_max) : min(za + ldi_eps, z0);   // origin nor past tmax
        float hbase = dot(vec2(px) + 0.5 - f, nuw);
        uint list = ls_list(k, px, size);
        uint best = LS_END;
        float bestD = 0.0;
        uint steps = 0u;
        for (uint i = ls_first(list); i != LS_END && steps < bound; i = ls_next(list, i), ++steps) {
            float D = ls_depth(i);
            if (D < lo) continue;
            if (D > hi) break;
            if (hbase + (D - z0) * nv <= ldi_bias) continue;     // on or below o's tangent plane
            best = i;
            bestD = D;
            if (dz >= 0.0) break;                                // ascending lists: the first is the nearest
        }
        if (best != LS_END) {
            float t = dz != 0.0 ? (bestD - z0) / dz : t_in;
            h.t = clamp(t, t_in, t_out);
            h.node = best;
            h.pos = o + (u * (float(px.x) + 0.5 - f.x) + w * (float(px.y) + 0.5 - f.y)) / ppu + v * (bestD - z0);
            return h;
        }
        if (t_out >= t_end) return h;
        if (ldi_max_cross != 0u && h.crossings >= ldi_max_cross) { h.ended = true; return h; }
        if (tnext.x <= tnext.y) { px.x += stp.x; t_in = tnext.x; tnext.x += tdelta.x; }
        else                    { px.y += stp.y; t_in = tnext.y; tnext.y += tdelta.y; }
        h.crossings++;
        if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, size))) return h;
    }
    h.ended = true;                                          // no float progress (NaN): a miss
    return h;
}
#endif
