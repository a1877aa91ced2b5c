// The compute G-buffer's triangle set-up, shared by its per-triangle raster (gbuffer/raster.glsl) and its tile
// raster of wide triangles (gbuffer/wide.glsl): both classify a triangle alike, and a pixel gets the same
// depth bits in both visibility passes.
//
// The triangle is projected with view_proj. Outside one clip plane with all three vertices: nothing.
// Crossing the near or far plane (or w <= 0 at a vertex), or a window coordinate beyond GB_WIDE_LIMIT
// pixels: clipped (gbuffer/clip.glsl); not finite: left to the hardware. Otherwise window coordinates
// (c.xy / c.w, viewport transform) are snapped to the hardware's sub-pixel grid, and a pixel centre is
// covered by the hardware's fill rule (gbuffer/fill_rule.glsl): in int32 for small triangles, whose
// coordinate differences stay below 2^14, in double for wide ones (exact below GB_WIDE_LIMIT). The window
// depth z = z_ndc / 2 + 1/2 is affine in window coordinates; it is the plane through the three vertices at
// the pixel centre, through the snapped ones with SPLAT_SNAPPED_PLANE (NVIDIA), else the given ones
// (llvmpipe), as the hardware interpolates. The depth is `precise`: a fragment is found again in pass 1 by
// its depth bits.
#include "gbuffer/position.glsl"
#include "gbuffer/fill_rule.glsl"
#include "gbuffer/vis.glsl"
uniform mat4 view_proj;
uniform int max_pixels;   // pixel centres of the (viewport-clamped) box rasterized by one invocation

const int GB_OUTSIDE = 0, GB_HARDWARE = 1, GB_SMALL = 2, GB_WIDE = 3, GB_CLIP = 4;
const float GB_MAX_EXTENT = 64.0;                                  // pixels: int32 edge functions
const float GB_WIDE_LIMIT = float(1 << (24 - LS_SUBPIXEL_BITS));   // pixels: |fixed point| < 2^24

struct GbTri {
    SpTri tri;      // snapped, counter-clockwise
    ivec2 i0, i1;   // the texel box, clamped to the viewport
    vec2 w0, dz;    // the depth plane: z0 at w0, gradient dz
    float z0;
};

bool gb_outside(float a, float b, float c) { return a > 0.0 && b > 0.0 && c > 0.0; }

void gb_clip_coords(uint t, out vec4 c0, out vec4 c1, out vec4 c2) {
    c0 = view_proj * vec4(gb_vertex(3u * t), 1.0);
    c1 = view_proj * vec4(gb_vertex(3u * t + 1u), 1.0);
    c2 = view_proj * vec4(gb_vertex(3u * t + 2u), 1.0);
}

bool gb_finite(vec4 c) { return !any(isnan(c)) && !any(isinf(c)); }

int gb_setup(uint t, out GbTri g) {
    vec4 c0, c1, c2;
    gb_clip_coords(t, c0, c1, c2);
    if (gb_outside(c0.x - c0.w, c1.x - c1.w, c2.x - c2.w) || gb_outside(-c0.x - c0.w, -c1.x - c1.w, -c2.x - c2.w)
        || gb_outside(c0.y - c0.w, c1.y - c1.w, c2.y - c2.w) || gb_outside(-c0.y - c0.w, -c1.y - c1.w, -c2.y - c2.w)
        || gb_outside(c0.z - c0.w, c1.z - c1.w, c2.z - c2.w) || gb_outside(-c0.z - c0.w, -c1.z - c1.w, -c2.z - c2.w))
        return GB_OUTSIDE;
    if (!(gb_finite(c0) && gb_finite(c1) && gb_finite(c2))) return GB_HARDWARE;
    if (min(min(c0.w, c1.w), c2.w) <= 0.0 || abs(c0.z) > c0.w || abs(c1.z) > c1.w || abs(c2.z) > c2.w)
        return GB_CLIP;   // crosses the near or far plane
    vec2 hs = vec2(vis_size) * 0.5;
    vec2 w0 = c0.xy / c0.w * hs + hs, w1 = c1.xy / c1.w * hs + hs, w2 = c2.xy / c2.w * hs + hs;
    vec2 lo = min(w0, min(w1, w2)), hi = max(w0, max(w1, w2));
    if (!(all(greaterThan(lo, vec2(-GB_WIDE_LIMIT))) && all(lessThan(hi, vec2(GB_WIDE_LIMIT)))))
        return GB_CLIP;
    const float S = float(SP_ONE);
    ivec2 f0 = ivec2(roundEven(w0 * S)), f1 = ivec2(roundEven(w1 * S)), f2 = ivec2(roundEven(w2 * S));
    ivec2 a = f1 - f0, b = f2 - f0;
    double area = double(a.x) * double(b.y) - double(a.y) * double(b.x);   // exact: |a|, |b| < 2^25
    if (area == 0.0) return GB_OUTSIDE;
    sp_texel_box(min(f0, min(f1, f2)), max(f0, max(f1, f2)), vis_size, g.i0, g.i1);
    if (any(greaterThan(g.i0, g.i1))) return GB_OUTSIDE;
    ivec2 box = g.i1 - g.i0 + 1;
    vec2 ext = hi - lo;
    bool wide = !(ext.x <= GB_MAX_EXTENT && ext.y <= GB_MAX_EXTENT) || box.x * box.y > max_pixels;
    float z0 = c0.z / c0.w * 0.5 + 0.5, z1 = c1.z / c1.w * 0.5 + 0.5, z2 = c2.z / c2.w * 0.5 + 0.5;
    bool cw = area < 0.0;
    g.tri = sp_ccw(f0, f1, f2, cw);
    sp_plane_vertices(g.tri.f0, g.tri.f1, g.tri.f2, cw, w0, w1, w2);
    if (cw) { float tz = z1; z1 = z2; z2 = tz; }   // counter-clockwise, as the triangle
    g.dz = sp_plane_gradient(w0, w1, w2, z0, z1, z2);
    g.w0 = w0;
    g.z0 = z0;
    return wide ? GB_WIDE : GB_SMALL;
}

float gb_depth(GbTri g, ivec2 px) {
    precise float z = g.z0 + dot(g.dz, vec2(px) + 0.5 - g.w0);   // the same bits in both passes
    return z;
}
