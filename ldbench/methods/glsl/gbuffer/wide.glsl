// The compute G-buffer's tile raster of wide triangles (gbuffer/wide_list.glsl): one 16 x 16 tile of a wide
// triangle's box per workgroup (grid-stride over the tile list), a pixel centre per invocation, covered by
// the fill rule in double (exact) and written to the visibility buffer as the per-triangle raster does,
// in both passes (vis_pass 0, 1). A clipped triangle's polygon (gbuffer/clip.glsl) is read from its record
// and writes the clipped triangle's id.
layout(local_size_x = 16, local_size_y = 16) in;
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"

// whether the centre of a texel is inside a clipped polygon: on the inner side of every edge, by the fill
// rule's bias on its edge (an edge of no length, two vertices snapped together, decides nothing)
bool gb_polygon_covers(GbPiece r, ivec2 texel) {
    ivec2 p = texel * SP_ONE + SP_HALF;
    int n = int(r.meta.y);
    for (int i = 0; i < n; ++i) {
        ivec2 a = r.f[i], e = r.f[i + 1 < n ? i + 1 : 0] - a;
        if (e != ivec2(0) && sp_edge_wide(e, a, p) < double(sp_bias(e))) return false;
    }
    return true;
}

void main() {
    uint total = min(gw_tiles, tile_capacity);
    for (uint v = gl_WorkGroupID.x; v < total; v += gl_NumWorkGroups.x) {
        uvec2 e = gt_map[v];
        if ((e.x & GB_PIECE) != 0u) {   // a clipped triangle's polygon
            GbPiece r = gc_piece[e.x & ~GB_PIECE];
            int tiles_x = (r.box.z - r.box.x + GB_TILE) / GB_TILE;
            ivec2 px = r.box.xy + GB_TILE * ivec2(int(e.y) % tiles_x, int(e.y) / tiles_x)
                     + ivec2(gl_LocalInvocationID.xy);
            if (all(lessThanEqual(px, r.box.zw)) && gb_polygon_covers(r, px)) {
                precise float z = r.plane.z + dot(r.dz.xy, vec2(px) + 0.5 - r.plane.xy);
                vis_fragment(r.meta.x, px, z);
            }
            continue;
        }
        GbTri g;
        gb_setup(e.x, g);   // the set-up pass 0 listed it with
        int tiles_x = (g.i1.x - g.i0.x + GB_TILE) / GB_TILE;
        ivec2 px = g.i0 + GB_TILE * ivec2(int(e.y) % tiles_x, int(e.y) / tiles_x) + ivec2(gl_LocalInvocationID.xy);
        if (all(lessThanEqual(px, g.i1)) && sp_covers_wide(g.tri, px)) vis_fragment(e.x, px, gb_depth(g, px));
    }
}
