// Weighted blended OIT (McGuire & Bavoil, JCGT 2(2), 2013), the accumulation pass: every fragment of the
// scene (both faces, no depth test) adds, with blending (ONE, ONE) on both targets,
//   target 0: (c a w, a w)      colour and coverage, weighted
//   target 1: (-log(1 - a), 1)  revealage as a sum of logarithms (the product of (1 - a) through one
//                               additive blend state: per-target blend functions are not exposed here),
//                               and the fragment count
// w = w(z, a) is the paper's depth weight (WEIGHT 7, 8, 9, 10: its equations; 0: constant 1, the weighted
// average of Bavoil & Myers 2008), z = the linear view depth (paper: |z| in camera-space units) and, for
// equation 10, d(z) = the window depth gl_FragCoord.z.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
in float v_depth;
flat in uint v_material;
layout(location = 0) out vec4 out_accum;
layout(location = 1) out vec4 out_reveal;

float weight(float z, float a) {
    z = abs(z);
#if WEIGHT == 7
    return a * clamp(10.0 / (1e-5 + pow(z / 5.0, 2.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
#elif WEIGHT == 8
    return a * clamp(10.0 / (1e-5 + pow(z / 10.0, 3.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3);
#elif WEIGHT == 9
    return a * clamp(0.03 / (1e-5 + pow(z / 200.0, 4.0)), 1e-2, 3e3);
#elif WEIGHT == 10
    return a * max(1e-2, 3e3 * pow(1.0 - gl_FragCoord.z, 3.0));
#else
    return 1.0;
#endif
}

void main() {
    vec4 m = oit_material[v_material];
    float a = m.a, w = weight(v_depth, a);
    out_accum = vec4(m.rgb * a * w, a * w);
    out_reveal = vec4(-log(max(1.0 - a, 1e-30)), 1.0, 0.0, 0.0);
}
#endif
