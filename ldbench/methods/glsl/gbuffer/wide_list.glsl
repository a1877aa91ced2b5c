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
