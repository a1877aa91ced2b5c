// The compute G-buffer's lists (gbuffer/wide_list.glsl), filled by its per-triangle raster (gbuffer/raster.glsl)
// and its clipper (gbuffer/clip.glsl): the triangles left to the hardware, an index list of one indirect draw
// (gb_cmd, gb_cmd[0] counts the indices; gbuffer/large.glsl), and the wide triangles and polygons the tile
// raster draws (gbuffer/wide.glsl).
layout(std430, binding = B_GBUF_LARGE) buffer GbufLarge { uint gb_cmd[8]; uint gb_large[]; };

void gb_to_hardware(uint t) {
    uint i = atomicAdd(gb_cmd[0], 3u);
    gb_large[i] = 3u * t;
    gb_large[i + 1u] = 3u * t + 1u;
    gb_large[i + 2u] = 3u * t + 2u;
}

// Lists a wide triangle (or a polygon: id = its record | GB_PIECE) with the tiles of its box; the tile list
// keeps those of its tiles that hold one of its pixel centres (gbuffer/wide_expand.glsl).
void gb_to_wide(uint id, GbTri g) {
    ivec2 tiles = (g.i1 - g.i0 + GB_TILE) / GB_TILE;
    uint slot = atomicAdd(gw_triangles, 1u);
    gw_list[slot] = uvec4(id, 0u, uint(tiles.x * tiles.y), 0u);
    atomicMax(gw_list_groups[0], min(slot + 1u, 65535u));
}
