// HBAO's deinterleave (access = "deinterleaved"): the G-buffer's view-space position and normal of pixel p
// into 4x4 layers of a quarter of the image each, layer (p & 3) at p >> 2 (layer (i, j) is the block of
// `quarter` texels at (i, j) * quarter). The values are the expressions hbao.glsl evaluates on the G-buffer
// (view * position, mat3(view) * normal), so reading them here gives the same image to float rounding.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = B_HBAO_LAYER_POSITION) writeonly uniform image2D out_layer_position;
layout(rgba32f, binding = B_HBAO_LAYER_NORMAL) writeonly uniform image2D out_layer_normal;
uniform sampler2D g_position;   // world position, w = 1 where hit
uniform sampler2D g_normal;     // camera-facing geometric normal (world)
uniform mat4 view;              // world -> view (rigid)
uniform ivec2 quarter;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(g_position, 0)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    ivec2 t = (p & 3) * quarter + (p >> 2);
    imageStore(out_layer_position, t, vec4((view * vec4(pos.xyz, 1.0)).xyz, pos.w));
    imageStore(out_layer_normal, t, vec4(mat3(view) * texelFetch(g_normal, p, 0).xyz, 0.0));
}
