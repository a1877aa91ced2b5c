// Dual depth peeling (Bavoil & Myers 2008): each geometry pass peels the nearest and the farthest layer left
// at every pixel. All targets blend with MAX, so every fragment writes a pass-through value by default:
//   target 0 (RG32F)   (-near, far) of the fragments still to peel: the next pass's depth interval
//   target 1 (RGBA32F) front accumulation (C, 1 - T), front to back: only the nearest fragment adds to it
//   target 2 (RGBA32F) this pass's farthest layer (albedo, opacity + 1: alpha >= 1 marks "a layer here",
//                      also for opacity 0), blended back to front by blend.glsl
// Depth is the linear view depth in float32 (no depth buffer). Fragments at exactly the same depth are
// peeled in the same pass and merge (MAX), as in the original algorithm: coincident surfaces are lost.
// Uniform init = 1: the first pass, min-max depth only (target 0).
// DDP_PASS_THROUGH (pass_through = true): Bavoil & Myers' original, every fragment of the scene writes all
// three targets in every pass (the front target is cleared, the fragments peeled earlier pass the front
// accumulation through). Default: the front target starts as a copy of front_prev, so the fragments peeled
// earlier are discarded (no texture read of the front, no blending); MAX over the same values: same output.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
uniform int init;                 // 1: the min-max pass
uniform sampler2D depth_prev;     // (-near, far) from the previous pass
uniform sampler2D front_prev;     // front accumulation of the previous pass
in float v_depth;
flat in uint v_material;
layout(location = 0) out vec2 out_depth;
layout(location = 1) out vec4 out_front;
layout(location = 2) out vec4 out_back;

void main() {
    float z = v_depth;
    if (init == 1) {
        out_depth = vec2(-z, z);
        out_front = vec4(0.0);
        out_back = vec4(0.0);
        return;
    }
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 nf = texelFetch(depth_prev, px, 0).xy;
    float nearest = -nf.x, farthest = nf.y;
#if !defined(DDP_PASS_THROUGH)
    // the front target already holds front_prev (copied before the pass): nothing to write
    if (z < nearest || z > farthest) discard;                                // peeled by an earlier pass
#endif
    vec4 front = texelFetch(front_prev, px, 0);
    out_depth = vec2(-OIT_FAR);
    out_front = front;
    out_back = vec4(0.0);
    if (z < nearest || z > farthest) return;                                 // peeled by an earlier pass
    if (z > nearest && z < farthest) { out_depth = vec2(-z, z); return; }    // for a later pass
    vec4 c = oit_material[v_material];
    if (z == nearest) {
        float T = 1.0 - front.a;
        out_front = vec4(front.rgb + T * c.a * c.rgb, 1.0 - T * (1.0 - c.a));
    } else {
        out_back = vec4(c.rgb, c.a + 1.0);
    }
}
#endif
