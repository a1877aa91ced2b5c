// The compute G-buffer's tile raster of wide triangles (gbuffer/wide_list.glsl): one 16 x 16 tile of a wide
// triangle's box per workgroup (grid-stride over the tile list), a pixel centre per invocation, covered by
// the fill rule in double (exact) and written to the visibility buffer as the per-triangle raster does,
// in both passes (vis_pass 0, 1). A clipped triangle's polygon (gbuffer/clip.glsl) is read from its record
// and writes the clipped triangle's id.
#include "gbuffer/vis_ext.glsl"
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
        GbPiece r;
        GbTri g;
        bool piece = gb_listed(e.x, r, g);   // a clipped triangle's polygon, set up in its record
        ivec2 px = gb_tile_origin(g.i0, g.i1, e.y) + ivec2(gl_LocalInvocationID.xy);
        if (any(greaterThan(px, g.i1))) continue;
        if (piece) {
            if (gb_polygon_covers(r, px)) {
                precise float z = r.plane.z + dot(r.dz.xy, vec2(px) + 0.5 - r.plane.xy);
                vis_fragment(r.meta.x, px, z);
            }
        } else if (sp_covers_wide(g.tri, px)) {
            vis_fragment(e.x, px, gb_depth(g, px));
        }
    }
}
