// The compute G-buffer's resolve (ldbench/methods/gbuffer.py, raster = "compute"): one invocation per pixel turns
// the visibility buffer's triangle id (gbuffer/vis.glsl) into the three textures of the hardware pass
// (gbuffer/gbuffer.glsl), same formats and meaning: world position (w = 1), the geometric normal flipped to the
// camera's side (w = material id), albedo; a pixel no triangle covers is 0 in all three, as the hardware
// pass's clear leaves it. The position is gbuffer/position.glsl's, as the hardware pass's.
#include "gbuffer/vis_ext.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_ALBEDO) readonly buffer Albedo { vec4 albedo[]; };
#include "gbuffer/position.glsl"
#include "gbuffer/vis.glsl"
layout(rgba32f, binding = B_GBUF_POSITION) writeonly uniform image2D gb_position;
layout(rgba32f, binding = B_GBUF_NORMAL) writeonly uniform image2D gb_normal;
layout(rgba32f, binding = B_GBUF_ALBEDO) writeonly uniform image2D gb_albedo;
uniform mat4 view_proj;
uniform vec3 eye;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, vis_size))) return;
    uint t = vis_triangle(uint(px.y * vis_size.x + px.x));
    if (t == 0xFFFFFFFFu) {
        imageStore(gb_position, px, vec4(0.0));
        imageStore(gb_normal, px, vec4(0.0));
        imageStore(gb_albedo, px, vec4(0.0));
        return;
    }
    vec3 pos = gb_pixel_position(t, px, vis_size, view_proj);
    uint o = 21u * t;
    vec3 n = normalize(vec3(gb_vtx[o + 3u], gb_vtx[o + 4u], gb_vtx[o + 5u]));
    float material = gb_vtx[o + 6u];
    if (dot(n, eye - pos) < 0.0) n = -n;   // two-sided: the side facing the camera (as gbuffer/gbuffer.glsl)
    imageStore(gb_position, px, vec4(pos, 1.0));
    imageStore(gb_normal, px, vec4(n, material));
    imageStore(gb_albedo, px, albedo[int(material + 0.5)]);
}
