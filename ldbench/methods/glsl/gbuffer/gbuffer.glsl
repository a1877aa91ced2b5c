// G-buffer pass: world position (w = 1 where a surface was hit), geometric normal flipped to face
// the camera (two-sided surfaces; w = material id), albedo. Rasterized with culling off. The position is
// gbuffer/position.glsl's (the pixel-centre ray met with the triangle's plane), not the interpolated one:
// the compute G-buffer's resolve computes the same.
#include "common/common.glsl"

#if defined(VERTEX_SHADER)
uniform mat4 view_proj;
in vec3 in_position;
in vec3 in_normal;
in float in_material;
flat out uint v_triangle;
flat out vec3 v_normal;
flat out float v_material;
void main() {
    v_triangle = uint(gl_VertexID) / 3u;   // the non-indexed triangle list: vertices 3t, 3t + 1, 3t + 2
    v_normal = in_normal;
    v_material = in_material;
    gl_Position = view_proj * vec4(in_position, 1.0);
}

#elif defined(FRAGMENT_SHADER)
#include "gbuffer/position.glsl"
uniform vec3 eye;
uniform mat4 view_proj;
uniform ivec2 size;
layout(std430, binding = B_ALBEDO) readonly buffer Albedo { vec4 albedo[]; };
flat in uint v_triangle;
flat in vec3 v_normal;
flat in float v_material;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;
void main() {
    vec3 pos = gb_pixel_position(v_triangle, ivec2(gl_FragCoord.xy), size, view_proj);
    vec3 n = normalize(v_normal);
    if (dot(n, eye - pos) < 0.0) n = -n;   // two-sided: the side facing the camera
    out_position = vec4(pos, 1.0);
    out_normal = vec4(n, v_material);
    out_albedo = albedo[int(v_material + 0.5)];
}
#endif
