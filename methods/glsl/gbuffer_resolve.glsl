// The compute G-buffer's resolve (methods/gbuffer.py, raster = "compute"): one invocation per pixel turns
// the visibility buffer's triangle id (gbuffer_vis.glsl) into the three textures of the hardware pass
// (gbuffer.glsl), same formats and meaning: world position (w = 1), the geometric normal flipped to the
// camera's side (w = material id), albedo; a pixel no triangle covers is 0 in all three, as the hardware
// pass's clear leaves it. The position is the perspective-correct interpolation at the pixel centre:
// barycentrics b with sum(b_i (x, y, w)_i) parallel to (x_ndc, y_ndc, 1), i.e. the camera ray through
// the pixel centre met with the triangle's plane.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_ALBEDO) readonly buffer Albedo { vec4 albedo[]; };
layout(std430, binding = B_GBUF_VERTICES) readonly buffer GbufVertices { float gb_vtx[]; };
#include "gbuffer_vis.glsl"
layout(rgba32f, binding = B_GBUF_POSITION) writeonly uniform image2D gb_position;
layout(rgba32f, binding = B_GBUF_NORMAL) writeonly uniform image2D gb_normal;
layout(rgba32f, binding = B_GBUF_ALBEDO) writeonly uniform image2D gb_albedo;
uniform mat4 view_proj;
uniform vec3 eye;

vec3 gb_vertex(uint i) { return vec3(gb_vtx[7u * i], gb_vtx[7u * i + 1u], gb_vtx[7u * i + 2u]); }

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, vis_size))) return;
    uint t = gv_vis[uint(vis_size.x * vis_size.y + px.y * vis_size.x + px.x)];
    if (t == 0xFFFFFFFFu) {
        imageStore(gb_position, px, vec4(0.0));
        imageStore(gb_normal, px, vec4(0.0));
        imageStore(gb_albedo, px, vec4(0.0));
        return;
    }
    vec3 v0 = gb_vertex(3u * t), v1 = gb_vertex(3u * t + 1u), v2 = gb_vertex(3u * t + 2u);
    vec3 c0 = (view_proj * vec4(v0, 1.0)).xyw, c1 = (view_proj * vec4(v1, 1.0)).xyw;
    vec3 c2 = (view_proj * vec4(v2, 1.0)).xyw;
    vec3 q = vec3((vec2(px) + 0.5) / vec2(vis_size) * 2.0 - 1.0, 1.0);
    vec3 b = vec3(dot(cross(c1, c2), q), dot(cross(c2, c0), q), dot(cross(c0, c1), q));
    b /= b.x + b.y + b.z;
    vec3 pos = b.x * v0 + b.y * v1 + b.z * v2;
    uint o = 21u * t;
    vec3 n = normalize(vec3(gb_vtx[o + 3u], gb_vtx[o + 4u], gb_vtx[o + 5u]));
    float material = gb_vtx[o + 6u];
    if (dot(n, eye - pos) < 0.0) n = -n;   // two-sided: the side facing the camera (as gbuffer.glsl)
    imageStore(gb_position, px, vec4(pos, 1.0));
    imageStore(gb_normal, px, vec4(n, material));
    imageStore(gb_albedo, px, albedo[int(material + 0.5)]);
}
