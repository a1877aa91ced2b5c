// Dual depth peeling's full-screen passes.
// Default: blend this pass's farthest layer over the back accumulation, back to front (SRC_ALPHA,
// ONE_MINUS_SRC_ALPHA); pixels without a back layer are discarded, so the occlusion query around this pass
// counts the pixels that had one (zero: every layer is peeled).
// DDP_FINAL: the output, front C + T_front · back (the back accumulation starts as the background), alpha =
// 1 where the pixel had a fragment (the min-max pass wrote a depth there).
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
void main() { gl_Position = oit_fullscreen(gl_VertexID); }

#elif defined(FRAGMENT_SHADER)
layout(location = 0) out vec4 out_color;
#if defined(DDP_FINAL)
uniform sampler2D front;
uniform sampler2D back;
uniform sampler2D depth_init;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 f = texelFetch(front, px, 0);
    vec3 b = texelFetch(back, px, 0).rgb;
    bool covered = texelFetch(depth_init, px, 0).y > -OIT_FAR;
    out_color = vec4(f.rgb + (1.0 - f.a) * b, covered ? 1.0 : 0.0);
}
#else
uniform sampler2D back_layer;
void main() {
    vec4 c = texelFetch(back_layer, ivec2(gl_FragCoord.xy), 0);
    if (c.a < 0.5) discard;
    out_color = vec4(c.rgb, c.a - 1.0);
}
#endif
#endif
