// The compute G-buffer's wide triangles (ldbench/methods/gbuffer.py, raster = "compute"): triangles whose window
// box is wider or taller than 64 pixels or holds more than max_pixels pixel centres, and the polygons of
// clipped triangles. Pass 0 of the per-triangle raster (gbuffer/raster.glsl) lists the wide triangles with
// the count of 16 x 16 tiles of their box, and the triangles to clip in gcl_tri; the clipper
// (gbuffer/clip.glsl) records each one's clipped polygon in gc_piece and lists it too, under its record with
// GB_PIECE set (a record holds everything the tile raster needs, set up once, so that both passes read the
// same numbers). gbuffer/wide_expand.glsl then appends the tiles that hold a pixel centre of theirs to the
// tile list, and gbuffer/wide.glsl rasterizes one tile per workgroup, a pixel per invocation, in both
// passes. The header holds the two indirect dispatches, their group counts raised (atomicMax) as entries
// are listed and tiles appended. A triangle with a tile beyond tile_capacity goes to the hardware path
// (its tiles that fitted are drawn too: the same triangle, so the same id).
const uint GB_PIECE = 0x80000000u;
const int GB_TILE = 16;
layout(std430, binding = B_GBUF_WIDE) buffer GbufWide {
    uint gw_tiles;          // tiles appended (may pass tile_capacity: only those below it are kept)
    uint gw_triangles;      // wide triangles and polygons listed
    uint gw_tile_groups[3]; // the indirect dispatch of gbuffer/wide.glsl (x = min(tiles, 65535), 1, 1)
    uint gw_list_groups[3]; // the indirect dispatch of gbuffer/wide_expand.glsl (x = min(triangles, 65535), 1, 1)
    uvec4 gw_list[];        // per wide triangle or polygon: (id, 0, tiles of its box, sent to the hardware)
};
layout(std430, binding = B_GBUF_TILES) buffer GbufTiles { uvec2 gt_map[]; };   // per tile: (id, tile of the box)
uniform uint tile_capacity;   // entries of gt_map

// the first texel of tile k of the box i0 .. i1 (tiles row by row)
ivec2 gb_tile_origin(ivec2 i0, ivec2 i1, uint k) {
    int tiles_x = (i1.x - i0.x + GB_TILE) / GB_TILE;
    return i0 + GB_TILE * ivec2(int(k) % tiles_x, int(k) / tiles_x);
}
struct GbPiece {
    vec4 plane;     // (x, y, z, 0): the depth plane's origin (window coordinates) and window depth there
    vec4 dz;        // (dz/dx, dz/dy, 0, 0)
    ivec4 box;      // the texel box: i0 = xy, i1 = zw, clamped to the viewport
    uvec4 meta;     // (the clipped triangle, the polygon's vertices n, 0, 0)
    ivec2 f[10];    // the polygon's vertices snapped to the sub-pixel grid, counter-clockwise (n <= 9)
};
layout(std430, binding = B_GBUF_CLIP) buffer GbufClip {
    uint gc_pieces;         // polygons recorded (may pass clip_capacity: only those below it are kept)
    uint gc_pad[3];
    GbPiece gc_piece[];
};
layout(std430, binding = B_GBUF_CLIP_LIST) buffer GbufClipList {
    uint gcl_count;     // triangles listed to clip (at most n_triangles)
    uint gcl_groups[3]; // the indirect dispatch of gbuffer/clip.glsl (x = min(groups, 65535), 1, 1)
    uint gcl_tri[];         // the triangles
};

// A listed entry (gw_list, gt_map): true for a polygon, its record in r and its box in g.i0, g.i1; false for a
// wide triangle, set up in g as pass 0 set it up (gb_setup: gbuffer/triangle.glsl comes before this file).
bool gb_listed(uint id, out GbPiece r, out GbTri g) {
    if ((id & GB_PIECE) != 0u) {
        r = gc_piece[id & ~GB_PIECE];
        g.i0 = r.box.xy;
        g.i1 = r.box.zw;
        return true;
    }
    gb_setup(id, g);
    return false;
}
