// HBAO's deinterleaved layers (access = "deinterleaved"), written by deinterleave.glsl and read by hbao.glsl:
// 4x4 layers of `quarter` texels each, layer (q & 3) holding pixel q at q >> 2, one layer after the other in a
// storage buffer. A buffer, not two RGBA32F images: the AO pass reads 2 x 16 bytes per sample, and plain
// loads of 16-byte values go through the L1 cache at a higher rate than texel fetches of 128-bit formats.
#ifndef LAYERS_ACCESS
#define LAYERS_ACCESS readonly
#endif
struct HbaoTexel {
    vec4 position;  // view-space position, w = 1 where hit
    vec4 normal;    // view-space normal (mat3(view) * the G-buffer's), w unused
};
layout(std430, binding = B_HBAO_LAYERS) LAYERS_ACCESS buffer HbaoLayers { HbaoTexel layers[]; };
uniform ivec2 quarter;          // the size of one layer (a multiple of the workgroup's 8 x 8)

int layer_index(ivec2 q) {      // pixel q's texel: layer (q & 3), at q >> 2 within it
    ivec2 cell = q & 3, t = q >> 2;
    return ((cell.y * 4 + cell.x) * quarter.y + t.y) * quarter.x + t.x;
}
