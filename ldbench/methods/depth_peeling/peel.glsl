// Depth peeling (Everitt 2001), front to back: one geometry pass per layer. The depth test (LESS) keeps the
// nearest fragment that lies strictly behind the layer peeled by the previous pass; its albedo and opacity
// go to the layer texture, composited by composite.glsl.
//
// Depth: the linear view depth mapped to [0, 1] over [near, far] and quantized to 2^20 steps k, written as
// gl_FragDepth = (16k + 8) / (2^24 - 1): the 24-bit depth buffer (moderngl's depth textures) stores 16k + 8
// give or take the float rounding of the conversions (a few units, never a neighbouring step), and the
// previous layer's k is read back from it exactly, so "behind the previous layer" is an integer comparison:
// a layer is never peeled twice or skipped. Surfaces within one step (2^-20 of the depth range) at a pixel
// are one layer to depth peeling: the depth test keeps the first to arrive and the others are lost.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
uniform vec2 depth_map;        // (near, 1 / (far - near))
uniform int first;             // 1 on the first pass: nothing peeled yet
uniform sampler2D prev_depth;  // the previous pass's depth buffer
in float v_depth;
flat in uint v_material;
layout(location = 0) out vec4 out_layer;

const float STEPS = 1048576.0;      // 2^20
const float D24 = 16777215.0;       // 2^24 - 1

float depth_step(float stored) { return floor(stored * D24 * 0.0625); }

void main() {
    float z = clamp((v_depth - depth_map.x) * depth_map.y, 0.0, 1.0);
    float k = min(floor(z * STEPS), STEPS - 2.0);
    if (first == 0 && k <= depth_step(texelFetch(prev_depth, ivec2(gl_FragCoord.xy), 0).r)) discard;
    gl_FragDepth = (16.0 * k + 8.0) / D24;
    out_layer = oit_material[v_material];
}
#endif
