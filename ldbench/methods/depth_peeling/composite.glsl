// Depth peeling's per-layer composite and final pass (full-screen triangles).
//
// Default: composite the layer just peeled under what is in front of it, with fixed-function blending
// (Bavoil & Myers 2008's front-to-back peeling): accumulation (rgb, T) with blend functions
// (DST_ALPHA, ONE) for colour and (ZERO, ONE_MINUS_SRC_ALPHA) for alpha, i.e. C += T α c, T *= 1 − α; the
// second target, R32F, counts the layers of each pixel (a target without alpha blends with A_d = 1: +1).
// OIT_FINAL: the output, C + T · background, alpha = 1 where the pixel had a layer.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
void main() { gl_Position = oit_fullscreen(gl_VertexID); }

#elif defined(FRAGMENT_SHADER)
#if defined(OIT_FINAL)
uniform sampler2D accum;
uniform sampler2D count;
uniform vec3 background;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(accum, px, 0);
    out_color = vec4(a.rgb + a.a * background, texelFetch(count, px, 0).r > 0.0 ? 1.0 : 0.0);
}
#else
uniform sampler2D layer;   // albedo, opacity of this pass's layer; alpha < 0: no fragment here
layout(location = 0) out vec4 out_accum;
layout(location = 1) out float out_count;
void main() {
    vec4 c = texelFetch(layer, ivec2(gl_FragCoord.xy), 0);
    if (c.a < 0.0) discard;
    out_accum = vec4(c.rgb * c.a, c.a);
    out_count = 1.0;
}
#endif
#endif
