// Reflective shadow map (Dachsbacher & Stamminger 2005) of the spot light: the scene rasterized from the
// light (ldbench/core/effects/vpl_range.py rsm_camera: the same view as the harness's Mitsuba RSM), depth-tested.
// Per texel: o_position = (p, 1) (w = 0: nothing), o_normal = the geometric normal facing the light,
// o_flux = (albedo · I · fall-off · Ω, area): the flux the texel's VPL reflects and the area it covers,
// Ω = (2 tan(cut-off) / R)² cos³α the texel's solid angle, area = Ω d² / max(|cos|, 0.05).
#include "common/common.glsl"

#if defined(VERTEX_SHADER)
uniform mat4 light_view_proj;
in vec3 in_position;
in vec3 in_normal;
in float in_material;
out vec3 v_world;
flat out vec3 v_normal;
flat out uint v_material;
void main() {
    gl_Position = light_view_proj * vec4(in_position, 1.0);
    v_world = in_position;
    v_normal = in_normal;
    v_material = uint(in_material + 0.5);
}

#elif defined(FRAGMENT_SHADER)
uniform SpotLight light;
uniform float texel_plane;      // (2 tan(cut-off) / R)²
layout(std430, binding = B_ALBEDO) readonly buffer Albedo { vec4 albedo[]; };
in vec3 v_world;
flat in vec3 v_normal;
flat in uint v_material;
layout(location = 0) out vec4 o_position;
layout(location = 1) out vec4 o_normal;
layout(location = 2) out vec4 o_flux;
void main() {
    vec3 d = v_world - light.position;
    float dist2 = dot(d, d);
    vec3 w = d * inversesqrt(dist2);
    vec3 n = normalize(v_normal);
    if (dot(n, w) > 0.0) n = -n;
    float cos_a = max(dot(w, light.axis), 0.0);
    float omega = texel_plane * cos_a * cos_a * cos_a;
    o_position = vec4(v_world, 1.0);
    o_normal = vec4(n, 0.0);
    o_flux = vec4(albedo[v_material].rgb * light.intensity * (spot_falloff(light, d) * omega),
                  omega * dist2 / max(-dot(n, w), 0.05));
}
#endif
