// The compute G-buffer's tile list (gbuffer/wide_list.glsl): a workgroup per listed wide triangle or clipped
// polygon appends an entry (id, k) for each tile k of its box that holds a pixel centre of it (grid-stride
// over the list). A tile whose pixel centres all lie outside one edge gets no entry, so the tile raster
// (gbuffer/wide.glsl) spends no workgroup on it: a long thin triangle, or a clipped floor seen from above,
// fills few of its box's tiles. Exact: an edge function is affine, and a tile's pixel centres lie in the
// rectangle of its corner pixels' centres, so its largest value over the tile is at one of those four. A
// triangle with a tile beyond tile_capacity goes to the hardware path, once.
#include "gbuffer/vis_ext.glsl"
layout(local_size_x = 256) in;
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"
#include "gbuffer/lists.glsl"

// whether every pixel centre of the tile lo .. hi (texels) is outside the edge from f along e
bool gb_tile_outside(ivec2 f, ivec2 e, int bias, ivec2 lo, ivec2 hi) {
    if (e == ivec2(0)) return false;   // (a clipped polygon's edge of no length decides nothing)
    ivec2 a = lo * SP_ONE + SP_HALF, b = hi * SP_ONE + SP_HALF;
    double m = max(max(sp_edge_wide(e, f, a), sp_edge_wide(e, f, ivec2(b.x, a.y))),
                   max(sp_edge_wide(e, f, ivec2(a.x, b.y)), sp_edge_wide(e, f, b)));
    return m < double(bias);
}

void main() {
    uint n = gw_triangles;
    for (uint s = gl_WorkGroupID.x; s < n; s += gl_NumWorkGroups.x) {
        uvec4 e = gw_list[s];
        GbPiece r;
        GbTri g;
        bool piece = gb_listed(e.x, r, g);   // the box and the edges of the listed triangle or polygon
        for (uint k = gl_LocalInvocationID.x; k < e.z; k += gl_WorkGroupSize.x) {
            ivec2 lo = gb_tile_origin(g.i0, g.i1, k);
            ivec2 hi = min(lo + GB_TILE - 1, g.i1);
            bool out_ = false;
            if (piece) {
                int m = int(r.meta.y);
                for (int j = 0; j < m && !out_; ++j) {
                    ivec2 d = r.f[j + 1 < m ? j + 1 : 0] - r.f[j];
                    out_ = gb_tile_outside(r.f[j], d, sp_bias(d), lo, hi);
                }
            } else {
                out_ = gb_tile_outside(g.tri.f0, g.tri.e0, g.tri.b0, lo, hi)
                    || gb_tile_outside(g.tri.f1, g.tri.e1, g.tri.b1, lo, hi)
                    || gb_tile_outside(g.tri.f2, g.tri.e2, g.tri.b2, lo, hi);
            }
            if (out_) continue;
            uint slot = gw_tiles < tile_capacity ? atomicAdd(gw_tiles, 1u) : tile_capacity;
            if (slot < tile_capacity) {
                gt_map[slot] = uvec2(e.x, k);
                atomicMax(gw_tile_groups[0], min(slot + 1u, 65535u));
            } else if (atomicExchange(gw_list[s].w, 1u) == 0u) {
                gb_to_hardware(piece ? r.meta.x : e.x);   // no room: the whole triangle, once
            }
        }
    }
}
