// LDI ray queries (the `rays` effect): one invocation per ray of the harness's batch (common/rays.glsl). A ray
// that points into the surface it starts on (dot(n, d) < 0) hits it at once: t = 0.
// LDI_STATS (an untimed statistics dispatch): ldi_stats[r] = (pixel crossings, LDI | ended << 31).
#include "ldi_trace.glsl"
#include "common/rays.glsl"

layout(local_size_x = 64) in;
uniform uint n_rays;
#if defined(LDI_STATS)
layout(std430, binding = B_LDI_STATS) writeonly buffer LdiStats { uvec2 ldi_stats[]; };
#endif

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= n_rays) return;
    vec3 o = rays[r].o_tmax.xyz, d = rays[r].d.xyz, n = rays[r].n.xyz;
    float tmax = rays[r].o_tmax.w;
    if (dot(n, d) < 0.0) {
#if defined(LDI_STATS)
        ldi_stats[r] = uvec2(0u, ldi_lookup(d));
#else
        ray_t[r] = 0.0;
#endif
        return;
    }
    LdiHit h = ldi_trace(o, d, n, tmax);
#if defined(LDI_STATS)
    ldi_stats[r] = uvec2(h.crossings, h.ldi | (h.ended ? 0x80000000u : 0u));
#else
    ray_t[r] = (h.t >= 0.0 && h.t <= tmax) ? h.t : RAY_MISS;
#endif
}
