// The compute G-buffer's raster (ldbench/methods/gbuffer.py, raster = "compute"): one invocation per triangle
// (grid-stride), run twice with vis_pass 0 (depth keys) then 1 (triangle ids) into the visibility buffer
// (gbuffer/vis.glsl); the resolve (gbuffer/resolve.glsl) turns it into the G-buffer's textures.
//
// Each triangle is projected with the G-buffer's view_proj. Outside one clip plane with all three
// vertices: nothing. Crossing the near or far plane (or w <= 0 at a vertex): left to the hardware, which
// clips it. Otherwise window coordinates (c.xy / c.w, viewport transform) are snapped to the hardware's
// sub-pixel grid and every pixel centre of the bounding box is tested with the hardware's fill rule
// (gbuffer/fill_rule.glsl). The window depth z = z_ndc / 2 + 1/2 is affine in window coordinates; it is
// the plane through the three vertices at the pixel centre, through the snapped ones with
// SPLAT_SNAPPED_PLANE (NVIDIA), else the given ones (llvmpipe), as the hardware interpolates.
//
// Pass 1 finds a fragment by its depth bits, so the depth is `precise` (no contraction or reordering that
// could differ between the two passes, e.g. after the compiler unswitched the loop on vis_pass).
//
// Large triangles: a window bounding box wider or taller than 64 pixels (int32 edge functions) or with
// more than max_pixels pixel centres in the viewport is appended by pass 0 to gb_large, the index list
// of one indirect draw (gb_cmd, gb_cmd[0] counts the indices) that the hardware rasterizes in both
// passes (gbuffer/large.glsl).
//
// Defines: LS_SUBPIXEL_BITS, SPLAT_TOP / BOTTOM / LEFT / RIGHT, SPLAT_SNAPPED_PLANE (the probe's rule).
layout(local_size_x = 64) in;
// geometry.vertices (ldbench/methods/gbuffer.py): per vertex position (3), face normal (3), material (1)
layout(std430, binding = B_GBUF_VERTICES) readonly buffer GbufVertices { float gb_vtx[]; };
layout(std430, binding = B_GBUF_LARGE) buffer GbufLarge { uint gb_cmd[8]; uint gb_large[]; };
#include "gbuffer/fill_rule.glsl"
#include "gbuffer/vis.glsl"
uniform mat4 view_proj;
uniform uint n_triangles;
uniform int max_pixels;   // pixel centres of the (viewport-clamped) bounding box rasterized here

const float GB_MAX_EXTENT = 64.0;   // pixels: coordinate differences < 2^14 keep edge functions in int32

void gb_to_hardware(uint t) {
    if (vis_pass != 0) return;   // pass 0 built the list; pass 1 draws it again
    uint i = atomicAdd(gb_cmd[0], 3u);
    gb_large[i] = 3u * t;
    gb_large[i + 1u] = 3u * t + 1u;
    gb_large[i + 2u] = 3u * t + 2u;
}

bool gb_outside(float a, float b, float c) { return a > 0.0 && b > 0.0 && c > 0.0; }

void gb_triangle(uint t) {
    uint o = 21u * t;
    vec3 v0 = vec3(gb_vtx[o], gb_vtx[o + 1u], gb_vtx[o + 2u]);
    vec3 v1 = vec3(gb_vtx[o + 7u], gb_vtx[o + 8u], gb_vtx[o + 9u]);
    vec3 v2 = vec3(gb_vtx[o + 14u], gb_vtx[o + 15u], gb_vtx[o + 16u]);
    vec4 c0 = view_proj * vec4(v0, 1.0), c1 = view_proj * vec4(v1, 1.0), c2 = view_proj * vec4(v2, 1.0);
    if (gb_outside(c0.x - c0.w, c1.x - c1.w, c2.x - c2.w) || gb_outside(-c0.x - c0.w, -c1.x - c1.w, -c2.x - c2.w)
        || gb_outside(c0.y - c0.w, c1.y - c1.w, c2.y - c2.w) || gb_outside(-c0.y - c0.w, -c1.y - c1.w, -c2.y - c2.w)
        || gb_outside(c0.z - c0.w, c1.z - c1.w, c2.z - c2.w) || gb_outside(-c0.z - c0.w, -c1.z - c1.w, -c2.z - c2.w))
        return;
    if (min(min(c0.w, c1.w), c2.w) <= 0.0 || abs(c0.z) > c0.w || abs(c1.z) > c1.w || abs(c2.z) > c2.w) {
        gb_to_hardware(t);   // crosses the near or far plane: the hardware clips
        return;
    }
    vec2 hs = vec2(vis_size) * 0.5;
    vec2 w0 = c0.xy / c0.w * hs + hs, w1 = c1.xy / c1.w * hs + hs, w2 = c2.xy / c2.w * hs + hs;
    vec2 ext = max(w0, max(w1, w2)) - min(w0, min(w1, w2));
    if (!(ext.x <= GB_MAX_EXTENT && ext.y <= GB_MAX_EXTENT)) {   // (or not finite)
        gb_to_hardware(t);
        return;
    }
    const float S = float(SP_ONE);
    ivec2 f0 = ivec2(roundEven(w0 * S)), f1 = ivec2(roundEven(w1 * S)), f2 = ivec2(roundEven(w2 * S));
    ivec2 a = f1 - f0, b = f2 - f0;
    int area = a.x * b.y - a.y * b.x;
    if (area == 0) return;
    ivec2 i0, i1;
    sp_texel_box(min(f0, min(f1, f2)), max(f0, max(f1, f2)), vis_size, i0, i1);
    if (any(greaterThan(i0, i1))) return;
    ivec2 box = i1 - i0 + 1;
    if (box.x * box.y > max_pixels) {
        gb_to_hardware(t);
        return;
    }
    float z0 = c0.z / c0.w * 0.5 + 0.5, z1 = c1.z / c1.w * 0.5 + 0.5, z2 = c2.z / c2.w * 0.5 + 0.5;
    bool cw = area < 0;
    SpTri tri = sp_ccw(f0, f1, f2, cw);
    sp_plane_vertices(tri.f0, tri.f1, tri.f2, cw, w0, w1, w2);
    if (cw) { float tz = z1; z1 = z2; z2 = tz; }   // counter-clockwise, as the triangle
    vec2 dz = sp_plane_gradient(w0, w1, w2, z0, z1, z2);
    for (int y = i0.y; y <= i1.y; ++y) {
        for (int x = i0.x; x <= i1.x; ++x) {
            if (!sp_covers(tri, ivec2(x, y))) continue;
            precise float z = z0 + dot(dz, vec2(x, y) + 0.5 - w0);   // the same bits in both passes
            vis_fragment(t, ivec2(x, y), z);
        }
    }
}

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint t = gl_GlobalInvocationID.x; t < n_triangles; t += stride) gb_triangle(t);
}
