// Ray queries through the CDI (cdi_trace.glsl) for the harness's batches, and the random-range baseline.
//   CDI_RAYS     (`rays`) one invocation per ray: rays[r] -> ray_t[r]; a ray into the surface it starts on
//                (dot(n, d) < 0) hits it at t = 0; a hit beyond t_max is a miss.
//   CDI_VPL      (`vpl_range`) one invocation per VPL i: its six rays rays[6i .. 6i+5] -> ray_t, and
//                vpl_range_out[i] = mean (range_max = 0) or max of min(t, cap), a miss counting cap.
//   CDI_RANDOM   (`vpl_range`, range = random) vpl_range_out[i] = (r_min + u (r_max - r_min)),
//                u = hash01(i, seed): no ray is cast.
#include "common/rays.glsl"
#include "vpl.glsl"
#if !defined(CDI_RANDOM)
#include "cdi_trace.glsl"
#endif
layout(local_size_x = 64) in;
uniform uint n_items;      // items of this dispatch; grid-stride loops (a dispatch has at most 65535 groups)
#define FOR_ITEMS(i) for (uint i = gl_GlobalInvocationID.x; i < n_items; i += gl_NumWorkGroups.x * 64u)
layout(std430, binding = B_VPL_RANGES) writeonly buffer VplRangeOut { float vpl_range_out[]; };

#if !defined(CDI_RANDOM)
float cdi_ray(uint r) {
    vec3 o = rays[r].o_tmax.xyz, d = rays[r].d.xyz, n = rays[r].n.xyz;
    float tmax = rays[r].o_tmax.w;
    if (dot(n, d) < 0.0) return 0.0;
    float sigma;
    uint k = cdi_nearest(d, sigma);
    float t = cdi_trace(k, sigma, o, n);
    return (t >= 0.0 && t <= tmax) ? t : RAY_MISS;
}
#endif

#if defined(CDI_RANDOM)
uniform uint seed;
uniform float r_min, r_max;     // world units
void main() {
    FOR_ITEMS(i) vpl_range_out[i] = r_min + hash01(i, seed) * (r_max - r_min);
}
#elif defined(CDI_VPL)
uniform float cap;
uniform int range_max;
void main() {
    FOR_ITEMS(i) {
        float acc = 0.0;
        for (uint k = 0u; k < 6u; ++k) {
            float t = cdi_ray(6u * i + k);
            ray_t[6u * i + k] = t;
            acc = range_accumulate(acc, t, cap, range_max);
        }
        vpl_range_out[i] = range_finish(acc, range_max);
    }
}
#else
void main() {
    FOR_ITEMS(r) ray_t[r] = cdi_ray(r);
}
#endif
