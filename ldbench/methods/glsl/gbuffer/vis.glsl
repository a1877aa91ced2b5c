// The compute G-buffer's visibility buffer (ldbench/methods/gbuffer.py, raster = "compute"), shared by its compute
// raster (gbuffer/raster.glsl) and the hardware raster of the triangles it leaves (gbuffer/large.glsl).
// gv_vis[0 .. W*H): per pixel the least depth key, gv_vis[W*H .. 2*W*H): the least triangle id among the
// fragments of that depth key; both cleared to 0xFFFFFFFF (nothing). Depth keys are the float bits of the
// window depth in [0, 1] (non-negative floats order as uints; the sign bit is dropped so -0 is 0).
// Pass 0 (vis_pass = 0) takes the least depth key, pass 1 the least id of the fragments at that key: the
// nearest fragment, ties to the smallest triangle id, as the hardware's depth test LESS in draw order.
// GB_VIS64: one 64-bit word a pixel instead, written in one pass (below). A program that includes this file
// starts with gbuffer/vis_ext.glsl (the extensions come before any other token).
uniform ivec2 vis_size;   // W, H
#if defined(GB_VIS64)
// One pass (GL_NV_shader_atomic_int64, where the GPU has it): gv_vis[i] = depth key << 32 | triangle id, so
// one atomicMin keeps the least key and, among its fragments, the least id: the two passes' result.
layout(std430, binding = B_GBUF_VIS) buffer GbufVis { uint64_t gv_vis[]; };

void vis_fragment(uint tri, ivec2 px, float z) {
    uint i = uint(px.y * vis_size.x + px.x);
    atomicMin(gv_vis[i], packUint2x32(uvec2(tri, floatBitsToUint(z) & 0x7FFFFFFFu)));
}

uint vis_triangle(uint i) { return unpackUint2x32(gv_vis[i]).x; }
#else
layout(std430, binding = B_GBUF_VIS) buffer GbufVis { uint gv_vis[]; };
uniform int vis_pass;     // 0: depth keys, 1: triangle ids

void vis_fragment(uint tri, ivec2 px, float z) {
    uint i = uint(px.y * vis_size.x + px.x);
    uint key = floatBitsToUint(z) & 0x7FFFFFFFu;
    if (vis_pass == 0) atomicMin(gv_vis[i], key);
    else if (gv_vis[i] == key) atomicMin(gv_vis[uint(vis_size.x * vis_size.y) + i], tri);
}

uint vis_triangle(uint i) { return gv_vis[uint(vis_size.x * vis_size.y) + i]; }
#endif
