// HBAO's deinterleaved layers (access = "deinterleaved"), written by deinterleave.glsl and read by hbao.glsl:
// 4x4 layers of `quarter` texels each, layer (q & 3) holding pixel q at q >> 2, one layer after the other in a
// storage buffer. A texel is what a sample needs, 16 bytes: the view-space normal (xyz) and the view-space
// depth z (w; < 0 where hit, 0 where not). The position is the pixel centre's view ray at that depth
// (view_point() in hbao.glsl): a G-buffer position and normal would be 32 bytes.
#ifndef LAYERS_ACCESS
#define LAYERS_ACCESS readonly restrict
#endif
layout(std430, binding = B_HBAO_LAYERS) LAYERS_ACCESS buffer HbaoLayers { vec4 layers[]; };
uniform ivec2 quarter;          // the size of one layer (a multiple of the workgroup's 8 x 8)

int layer_index(ivec2 q) {      // pixel q's texel: layer (q & 3), at q >> 2 within it
    ivec2 cell = q & 3, t = q >> 2;
    return ((cell.y * 4 + cell.x) * quarter.y + t.y) * quarter.x + t.x;
}
