// The compute G-buffer's wide triangles (ldbench/methods/gbuffer.py, raster = "compute"): triangles whose window
// box is wider or taller than 64 pixels or holds more than max_pixels pixel centres. Pass 0 of the
// per-triangle raster (gbuffer/raster.glsl) lists them with a range of 16 x 16 tiles of their box each;
// gbuffer/wide_expand.glsl writes one tile entry per tile; gbuffer/wide.glsl rasterizes one tile per
// workgroup, a pixel per invocation, in both passes. The header holds the two indirect dispatches, their
// group counts raised by pass 0 (atomicMax) as it lists triangles and reserves tiles.
// A triangle whose tiles do not fit tile_capacity goes to the hardware path instead (its reserved tiles are
// written as GB_NONE and skipped). Pass 0 lists the triangles to clip in gcl_tri; the clipper
// (gbuffer/clip.glsl) records each one's clipped polygon in gc_piece and lists it as a wide triangle too,
// under its record with GB_PIECE set. A record holds everything the tile raster needs, set up once, so that
// both passes read the same numbers.
const uint GB_NONE = 0xFFFFFFFFu;
const uint GB_PIECE = 0x80000000u;
const int GB_TILE = 16;
layout(std430, binding = B_GBUF_WIDE) buffer GbufWide {
    uint gw_tiles;          // tiles reserved (may pass tile_capacity: only those below it are used)
    uint gw_triangles;      // wide triangles listed
    uint gw_tile_groups[3]; // the indirect dispatch of gbuffer/wide.glsl (x = min(tiles, 65535), 1, 1)
    uint gw_list_groups[3]; // the indirect dispatch of gbuffer/wide_expand.glsl (x = min(triangles, 65535), 1, 1)
    uvec4 gw_list[];        // per wide triangle: (triangle or GB_NONE, first tile, tiles, 0)
};
layout(std430, binding = B_GBUF_TILES) buffer GbufTiles { uvec2 gt_map[]; };   // per tile: (triangle, tile)
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
