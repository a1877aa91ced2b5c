// The compute G-buffer's per-triangle raster (ldbench/methods/gbuffer.py, raster = "compute"): one invocation per
// triangle (grid-stride), run twice with vis_pass 0 (depth keys) then 1 (triangle ids) into the visibility
// buffer (gbuffer/vis.glsl); the resolve (gbuffer/resolve.glsl) turns it into the G-buffer's textures.
// gbuffer/triangle.glsl sets a triangle up and sorts it:
// - small (a box of at most 64 x 64 pixels and max_pixels pixel centres): every pixel centre of its box
//   tested here;
// - wide: listed by pass 0 for the tile raster (gbuffer/wide_list.glsl, gbuffer/wide.glsl);
// - crossing the near or far plane, beyond the exact range, or wide without room in the tile list: appended
//   by pass 0 to gb_large, the index list of one indirect draw (gb_cmd, gb_cmd[0] counts the indices) that
//   the hardware rasterizes in both passes (gbuffer/large.glsl).
//
// Defines: LS_SUBPIXEL_BITS, SPLAT_TOP / BOTTOM / LEFT / RIGHT, SPLAT_SNAPPED_PLANE (the probe's rule).
layout(local_size_x = 64) in;
layout(std430, binding = B_GBUF_LARGE) buffer GbufLarge { uint gb_cmd[8]; uint gb_large[]; };
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"
uniform uint n_triangles;

void gb_to_hardware(uint t) {
    uint i = atomicAdd(gb_cmd[0], 3u);
    gb_large[i] = 3u * t;
    gb_large[i + 1u] = 3u * t + 1u;
    gb_large[i + 2u] = 3u * t + 2u;
}

// Lists a wide triangle and reserves its tiles; to the hardware when they do not fit below tile_capacity
// (the check before the reservation keeps the count from wrapping around). Tiles reserved without room
// are listed under GB_NONE, so that gbuffer/wide_expand.glsl marks them skipped.
void gb_to_wide(uint t, GbTri g) {
    ivec2 tiles = (g.i1 - g.i0 + GB_TILE) / GB_TILE;
    uint n = uint(tiles.x * tiles.y);
    bool reserved = n <= tile_capacity && gw_tiles <= tile_capacity - n;
    uint base = reserved ? atomicAdd(gw_tiles, n) : 0u;
    bool fits = reserved && base <= tile_capacity - n;
    uint slot = atomicAdd(gw_triangles, 1u);
    gw_list[slot] = uvec4(fits ? t : GB_NONE, base, reserved ? n : 0u, 0u);
    atomicMax(gw_list_groups[0], min(slot + 1u, 65535u));
    if (reserved) atomicMax(gw_tile_groups[0], min(base + n, 65535u));
    if (!fits) gb_to_hardware(t);
}

void gb_triangle(uint t) {
    GbTri g;
    int kind = gb_setup(t, g);
    if (kind == GB_HARDWARE || kind == GB_WIDE) {
        if (vis_pass != 0) return;   // pass 0 listed it; pass 1 draws the same lists again
        if (kind == GB_HARDWARE) gb_to_hardware(t);
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
