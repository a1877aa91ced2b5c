// HBAO's deinterleave (access = "deinterleaved"): the G-buffer's view-space depth and normal of pixel p into
// the 4x4 layers of layers.glsl. The values are the expressions hbao.glsl evaluates on the G-buffer
// (view_z, mat3(view) * normal), so reading them there gives the same image to float rounding.
#define LAYERS_ACCESS writeonly
#include "layers.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D g_position;   // world position, w = 1 where hit
uniform sampler2D g_normal;     // camera-facing geometric normal (world)
uniform mat4 view;              // world -> view (rigid)

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(g_position, 0)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    float z = pos.w >= 0.5 ? (view * vec4(pos.xyz, 1.0)).z : 0.0;
    layers[layer_index(p)] = vec4(mat3(view) * texelFetch(g_normal, p, 0).xyz, z);
}
