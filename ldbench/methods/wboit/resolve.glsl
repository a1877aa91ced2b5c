// Weighted blended OIT's resolve (full-screen triangle): C = accum.rgb / clamp(accum.a, 1e-4, 5e4)
// × (1 − R) + R × background, R = Π(1 − a) = exp(−Σ −log(1 − a)); alpha = 1 where a fragment landed.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
void main() { gl_Position = oit_fullscreen(gl_VertexID); }

#elif defined(FRAGMENT_SHADER)
uniform sampler2D accum;
uniform sampler2D reveal;
uniform vec3 background;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 acc = texelFetch(accum, px, 0);
    vec2 rv = texelFetch(reveal, px, 0).rg;
    if (rv.g < 0.5) { out_color = vec4(background, 0.0); return; }
    float R = exp(-rv.r);
    out_color = vec4(acc.rgb / clamp(acc.a, 1e-4, 5e4) * (1.0 - R) + R * background, 1.0);
}
#endif
