// LDM ambient occlusion / obscurance (aalund2015 §3.3, §4.1): one invocation per G-buffer pixel, a
// loop over the N maps; each map contributes the one of its two directions +-v in the hemisphere of
// the camera-facing normal. V = 1 - rho(t) (core/effects/ao.py), weighted by cos(theta).
// estimator 0 ("ratio"):  A = sum V cos / sum cos   (exact when nothing is hit)
// estimator 1 ("paper"):  A = 2/N sum V cos          (aalund2015 eq. 2)
// Background pixels hold 1. LDM_ONE_WAY (trace.query = one_way: 2N maps along +-v_i, each answering its own
// axis): only the maps whose axis lies in the hemisphere contribute, the same N directions as two-way maps.
#include "ldm_trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform uint n_maps;
uniform float bias;        // world units
uniform float d_max;       // world units (3e38 = unbounded)
uniform int falloff;       // 0 step, 1 quadratic
uniform int estimator;     // 0 ratio, 1 paper

float rho(float t) {
    if (t >= d_max) return 0.0;
    if (falloff == 0) return 1.0;
    float q = t / d_max;
    return 1.0 - q * q;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(out_image)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    if (pos.w < 0.5) { imageStore(out_image, p, vec4(1.0)); return; }
    vec3 x = pos.xyz;
    vec3 n = normalize(texelFetch(g_normal, p, 0).xyz);
    float sum_vc = 0.0, sum_c = 0.0;
    for (uint k = 0u; k < n_maps; ++k) {
        float c = dot(n, ol_axes[k].v.xyz);
        float ct = abs(c);
        if (ct < 1e-6) continue;
#if defined(LDM_ONE_WAY)
        if (c < 0.0) continue;  // a one-way map answers +v_k only: the maps facing away give no direction
#endif
        float t = ldm_trace(k, c > 0.0 ? 1.0 : -1.0, x, n, bias);
        float V = t >= 0.0 ? 1.0 - rho(t) : 1.0;
        sum_vc += V * ct;
        sum_c += ct;
    }
#if defined(LDM_ONE_WAY)
    float n_dirs = 0.5 * float(n_maps);   // 2N one-way maps answer the N directions of the hemisphere
#else
    float n_dirs = float(n_maps);
#endif
    float A = estimator == 0 ? (sum_c > 0.0 ? sum_vc / sum_c : 1.0) : 2.0 / n_dirs * sum_vc;
    imageStore(out_image, p, vec4(A));
}
