// The compute G-buffer's tile raster of wide triangles (gbuffer/wide_list.glsl): one 16 x 16 tile of a wide
// triangle's box per workgroup (grid-stride over the tile list), a pixel centre per invocation, covered by
// the fill rule in double (exact) and written to the visibility buffer as the per-triangle raster does,
// in both passes (vis_pass 0, 1).
layout(local_size_x = 16, local_size_y = 16) in;
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"

void main() {
    uint total = min(gw_tiles, tile_capacity);
    for (uint v = gl_WorkGroupID.x; v < total; v += gl_NumWorkGroups.x) {
        uvec2 e = gt_map[v];
        if (e.x == GB_NONE) continue;
        GbTri g;
        gb_setup(e.x, g);   // the set-up pass 0 listed it with
        int tiles_x = (g.i1.x - g.i0.x + GB_TILE) / GB_TILE;
        ivec2 px = g.i0 + GB_TILE * ivec2(int(e.y) % tiles_x, int(e.y) / tiles_x) + ivec2(gl_LocalInvocationID.xy);
        if (all(lessThanEqual(px, g.i1)) && sp_covers_wide(g.tri, px)) vis_fragment(e.x, px, gb_depth(g, px));
    }
}
