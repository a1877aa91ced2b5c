// Apply the light grid (archer2019 §3.2): one invocation per G-buffer pixel x (camera-facing normal n,
// albedo ρ); the VPLs of x's cell, each a small Lambertian patch {y, n_y, Φ, area A}, unshadowed and cut
// off at its range:
//   L(x) = ρ/π Σ_{|y - x| < range} Φ cos θ_x cos θ_y / (π (|y - x|² + A/π))
// (one diffuse bounce; A/π bounds the 1/d² singularity as a disk of area A seen on its axis does).
#include "common/common.glsl"
#include "grid_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
struct Vpl { vec4 pos_range; vec4 normal_area; vec4 flux; };
layout(std430, binding = B_VPLS) readonly buffer Vpls { Vpl vpls[]; };
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
layout(rgba32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_image);
    if (px.x >= size.x || px.y >= size.y) return;
    vec4 p = texelFetch(g_position, px, 0);
    if (p.w < 0.5) { imageStore(out_image, px, vec4(0.0)); return; }
    vec3 x = p.xyz, n = texelFetch(g_normal, px, 0).xyz;
    vec3 rho = texelFetch(g_albedo, px, 0).rgb;
    uint c = grid_cell_index(grid_cell_of(x));
    vec3 sum = vec3(0.0);
    for (uint i = grid_begin(c), e = grid_end(c); i < e; ++i) {
        Vpl L = vpls[grid_idx[i]];
        vec3 d = L.pos_range.xyz - x;
        float d2 = dot(d, d);
        float r = L.pos_range.w;
        if (d2 >= r * r) continue;
        float inv = inversesqrt(max(d2, 1e-30));
        float cx = max(dot(n, d) * inv, 0.0), cy = max(-dot(L.normal_area.xyz, d) * inv, 0.0);
        sum += L.flux.rgb * (cx * cy / (d2 + L.normal_area.w / PI));
    }
    imageStore(out_image, px, vec4(rho / PI * sum / PI, 1.0));
}
