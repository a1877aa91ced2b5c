// LDM ray queries (the `rays` effect): one invocation per ray. The map whose axis v_k is nearest to the
// ray direction answers it along sigma * v_k with the same two-way list query as the AO pass
// (ldm_trace.glsl); the answer is a distance along v_k, the approximation the method makes. A ray that
// points into the surface it starts on (dot(n, d) < 0) hits that surface at once: t = 0.
// LDM_ANGLE_STATS (an untimed statistics dispatch): ldm_angle[r] = the angle between ray r and its
// map's direction, in degrees, instead of tracing.
#include "ldm_trace.glsl"
#include "common/rays.glsl"

layout(local_size_x = 64) in;
uniform uint n_rays;
uniform uint n_maps;
uniform float bias;       // world units
#if defined(LDM_ANGLE_STATS)
layout(std430, binding = B_LDM_ANGLE) writeonly buffer LdmAngle { float ldm_angle[]; };
#endif

void main() {   // a 2D grid of workgroups (ldbench/methods/scan.py groups_2d): any number of rays
    uint r = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;
    if (r >= n_rays) return;
    vec3 o = rays[r].o_tmax.xyz, d = rays[r].d.xyz, n = rays[r].n.xyz;
    float tmax = rays[r].o_tmax.w;
#if !defined(LDM_ANGLE_STATS)
    if (dot(n, d) < 0.0) { ray_t[r] = 0.0; return; }
#endif
    float sigma;
    uint k = ldm_find_map(d, n_maps, sigma);
#if defined(LDM_ANGLE_STATS)
    ldm_angle[r] = degrees(acos(clamp(sigma * dot(d, ol_axes[k].v.xyz), -1.0, 1.0)));
    return;
#endif
    float t = ldm_trace(k, sigma, o, n, bias);
    ray_t[r] = (t >= 0.0 && t <= tmax) ? t : RAY_MISS;
}
