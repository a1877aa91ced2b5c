// MLAB's resolve (full-screen triangle): the pixel's layers front to back, C = Σ T_prefix C_i, then
// + Π T_i × background; alpha = 1 where a fragment landed.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
void main() { gl_Position = oit_fullscreen(gl_VertexID); }

#elif defined(FRAGMENT_SHADER)
layout(std430, binding = B_MLAB_LAYERS) readonly buffer MlabLayers { vec4 layer[]; };
layout(std430, binding = B_MLAB_COUNTS) readonly buffer MlabCounts { uint count[]; };
uniform ivec2 size;
uniform vec3 background;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    uint px = uint(p.y * size.x + p.x), n = count[px], base = px * uint(K);
    vec3 C = vec3(0.0);
    float T = 1.0;
    for (uint i = 0u; i < n; ++i) {
        vec4 L = layer[base + i];
        C += T * L.rgb;
        T *= L.a;
    }
    out_color = vec4(C + T * background, n > 0u ? 1.0 : 0.0);
}
#endif
