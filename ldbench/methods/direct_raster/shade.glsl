// Direct light from the spot light at every G-buffer pixel: albedo/pi * I * falloff * cos / d^2 * V,
// V from the cube shadow atlas. Background pixels are 0.
#include "common/common.glsl"
#include "lights/cube_shadow.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform sampler2D shadow_atlas;
uniform mat4 face_vp[6];
uniform SpotLight light;
uniform float normal_offset;   // world units per unit of distance to the light (texel footprint)
uniform float depth_bias;      // world units

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(out_image)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    vec3 L = vec3(0.0);
    if (pos.w > 0.5) {
        vec3 n = texelFetch(g_normal, p, 0).xyz;
        vec3 irr = spot_irradiance(light, pos.xyz, n);
        if (any(greaterThan(irr, vec3(0.0)))) {
            float d = distance(pos.xyz, light.position);
            vec3 x = pos.xyz + n * normal_offset * d;   // normal-offset shadow lookup
            float vis = cube_shadow(shadow_atlas, face_vp, light.position, x, depth_bias);
            L = texelFetch(g_albedo, p, 0).rgb / PI * irr * vis;
        }
    }
    imageStore(out_image, p, vec4(L, 1.0));
}
