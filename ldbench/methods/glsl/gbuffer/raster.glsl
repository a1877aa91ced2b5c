// The compute G-buffer's per-triangle raster (ldbench/methods/gbuffer.py, raster = "compute"): one invocation per
// triangle (grid-stride), run twice with vis_pass 0 (depth keys) then 1 (triangle ids) into the visibility
// buffer (gbuffer/vis.glsl); the resolve (gbuffer/resolve.glsl) turns it into the G-buffer's textures.
// gbuffer/triangle.glsl sets a triangle up and sorts it:
// - small (a box of at most 64 x 64 pixels and max_pixels pixel centres): every pixel centre of its box
//   tested here;
// - wide: listed by pass 0 for the tile raster (gbuffer/wide_list.glsl, gbuffer/wide.glsl);
// - crossing the near or far plane, or beyond the exact range: listed by pass 0 for the clipper
//   (gbuffer/clip.glsl), which records its polygon in gc_piece (at most clip_capacity) and lists it for the
//   tile raster;
// - not finite: appended by pass 0 to gb_large, the index list of one indirect draw (gb_cmd, gb_cmd[0]
//   counts the indices) that the hardware rasterizes in both passes (gbuffer/large.glsl); so are the
//   triangles the clipper or the tile list find no room for.
//
// GB_VIS64: one pass, each fragment's depth key and id in one 64-bit atomic (gbuffer/vis.glsl).
// Defines: LS_SUBPIXEL_BITS, SPLAT_TOP / BOTTOM / LEFT / RIGHT, SPLAT_SNAPPED_PLANE (the probe's rule).
#include "gbuffer/vis_ext.glsl"
layout(local_size_x = 64) in;
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"
#include "gbuffer/lists.glsl"
uniform uint n_triangles;

// Lists triangle t for the clipper, which pass 0 runs next (an indirect dispatch of 64-wide groups).
void gb_to_clip(uint t) {
    uint i = atomicAdd(gcl_count, 1u);
    gcl_tri[i] = t;
    atomicMax(gcl_groups[0], min(i / 64u + 1u, 65535u));
}

void gb_triangle(uint t) {
    GbTri g;
    int kind = gb_setup(t, g);
    if (kind == GB_HARDWARE || kind == GB_WIDE || kind == GB_CLIP) {
#if !defined(GB_VIS64)
        if (vis_pass != 0) return;   // pass 0 listed it; pass 1 draws the same lists again
#endif
        if (kind == GB_CLIP) gb_to_clip(t);
        else if (kind == GB_HARDWARE) gb_to_hardware(t);
        else gb_to_wide(t, g);
        return;
    }
    if (kind != GB_SMALL) return;
    for (int y = g.i0.y; y <= g.i1.y; ++y) {
        for (int x = g.i0.x; x <= g.i1.x; ++x) {
            if (sp_covers(g.tri, ivec2(x, y))) vis_fragment(t, ivec2(x, y), gb_depth(g, ivec2(x, y)));
        }
    }
}

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint t = gl_GlobalInvocationID.x; t < n_triangles; t += stride) gb_triangle(t);
}
