// Omnidirectional shadow map in a 6-face atlas (faces side by side: +X -X +Y -Y +Z -Z), storing the
// linear distance to the light. Works for spot lights of any cutoff and for point lights.
#include "common/common.glsl"

#if defined(VERTEX_SHADER)
uniform mat4 view_proj;
in vec3 in_position;
out vec3 v_position;
void main() {
    v_position = in_position;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
#elif defined(FRAGMENT_SHADER)
uniform vec3 light_pos;
in vec3 v_position;
layout(location = 0) out float out_distance;
void main() { out_distance = distance(v_position, light_pos); }
#endif

#if !defined(VERTEX_SHADER) && !defined(FRAGMENT_SHADER)
// Lookup side, included by shading passes. face_vp[i] is the view-projection of face i.
int cube_face(vec3 v) {
    vec3 a = abs(v);
    if (a.x >= a.y && a.x >= a.z) return v.x > 0.0 ? 0 : 1;
    if (a.y >= a.z) return v.y > 0.0 ? 2 : 3;
    return v.z > 0.0 ? 4 : 5;
}

// 1 if x is lit: distance to the light not beyond the stored occluder distance (+ bias).
float cube_shadow(sampler2D atlas, mat4 face_vp[6], vec3 light_pos, vec3 x, float bias) {
    vec3 v = x - light_pos;
    int f = cube_face(v);
    vec4 clip = face_vp[f] * vec4(x, 1.0);
    vec2 uv = clamp(clip.xy / clip.w * 0.5 + 0.5, 0.0, 1.0);
    ivec2 size = textureSize(atlas, 0);
    int s = size.y;
    ivec2 texel = ivec2(min(uv * float(s), vec2(s - 1)));
    float stored = texelFetch(atlas, ivec2(texel.x + f * s, texel.y), 0).r;
    return length(v) <= stored + bias ? 1.0 : 0.0;
}
#endif
