// Image effects of the LDI adapter: one invocation per G-buffer pixel x1 (normal n1 facing the camera,
// albedo a1), N secondary rays traced through the LDIs (ldi_trace.glsl). Random numbers: a PCG hash of
// (pixel, sample, seed) (sample_stream); origin, frame and warps of common/conventions.glsl (spawn_origin, the
// offset of the references and of the rays effect's batches; the G-buffer has no triangle, so no crease
// point).
//
// The samples of a pixel may be split over several dispatches (samples_per_dispatch): each sample has its own
// random stream, sums are kept in the output image between dispatches, the last one writes the value.
// (llvmpipe ends any loop after 65,535 iterations, counted over nested loops: many rays per invocation
// would silently lose samples there.)
//
// EFFECT 1 `indirect` (the paper's diffuse pass): w cosine-distributed about n1; at the hit x2 (normal n2
//   facing x1, from the fragment's payload; albedo a2, the float albedo of the payload's material id) the
//   spot light's direct light L_d(x2) = a2/pi * I * falloff * cos2 / d^2 * V, V from the cube shadow map
//   (the paper's "local lighting model including a shadow map"). Writes E = mean L_d (rgb) and 1; the
//   filter pass (blur.glsl) blurs E and multiplies by a1 (pdf cos/pi and BRDF a1/pi cancel to a1).
// EFFECT 2 `glossy_indirect`: w from the normalized Phong lobe (e+1)/(2pi) cos^e(alpha) about the mirror
//   direction of the view ray; BRDF a1 (e+2)/(2pi) cos^e(alpha), so a sample weighs a1 (e+2)/(e+1) cos(theta)
//   (0 below the surface). Writes the final radiance.
// EFFECT 3 `soft_shadows`: the spot light's unshadowed direct term at x1 times the fraction of shadow rays
//   towards points uniform (by area) on the sphere of light_radius around the light that reach it
//   (t_max = distance * (1 - shadow_eps)). Writes the final radiance.
#include "common/common.glsl"
#include "common/conventions.glsl"
#include "lights/cube_shadow.glsl"
#include "ldi_trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = B_OUT_IMAGE) uniform image2D out_image;   // sums between dispatches, then the value
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform SpotLight light;
uniform int spp;            // rays per pixel
uniform int sample_base;    // this dispatch traces samples [sample_base, sample_base + sample_count)
uniform int sample_count;
uniform uint seed;
uniform vec3 eye;
uniform float ray_eps;
#if EFFECT != 3
uniform sampler2D shadow_atlas;
uniform mat4 face_vp[6];
uniform float normal_offset;
uniform float depth_bias;
#endif
#if EFFECT == 2
uniform float exponent;
#endif
#if EFFECT != 3
// albedo of each material (SceneGeometry.albedo), indexed by the fragment's material id: the exact float
// albedo, not an 8-bit copy in the payload
layout(std430, binding = B_LS_ALBEDO) readonly buffer LSAlbedo { vec4 ls_albedo[]; };
#endif
#if EFFECT == 3
uniform float light_radius;
uniform float shadow_eps;
#endif
#if defined(LDI_STATS)
layout(std430, binding = B_LDI_STATS) buffer LdiStats { uvec4 ldi_stats[]; };   // per pixel: sum, max, ended, rays
#endif

#if EFFECT != 3
// Direct light leaving the hit fragment towards the ray's origin (two-sided: n2 faces the origin), shaded
// at the fragment's own point (on the surface, within a pixel of the ray's approximate hit: a point
// off the surface would be shadowed by its own surface in the shadow map).
vec3 hit_radiance(vec3 o, vec3 d, LdiHit hit) {
    vec3 x2 = hit.pos;
    vec3 n2 = ls_unpack_normal(ls_payload(hit.node, uint(LS_PL_NORMAL)));
    if (dot(n2, d) > 0.0) n2 = -n2;
    vec3 irr = spot_irradiance(light, x2, n2);
    if (all(equal(irr, vec3(0.0)))) return vec3(0.0);
    float dist = distance(x2, light.position);
    float vis = cube_shadow(shadow_atlas, face_vp, light.position, x2 + n2 * normal_offset * dist, depth_bias);
    vec3 a2 = ls_albedo[ls_payload(hit.node, uint(LS_PL_MATERIAL))].rgb;
    return a2 / PI * irr * vis;
}
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_image);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    if (pos.w < 0.5) { imageStore(out_image, p, vec4(0.0)); return; }
    vec3 x = pos.xyz, n = texelFetch(g_normal, p, 0).xyz;
    vec3 o = spawn_origin(x, n, ray_eps);   // the references' and the rays batch's offset
    uint pix = uint(p.y * size.x + p.x);
    vec4 acc = sample_base > 0 ? imageLoad(out_image, p) : vec4(0.0);   // sums of the earlier dispatches
#if defined(LDI_STATS)
    uvec4 st = sample_base > 0 ? ldi_stats[pix] : uvec4(0u);
#endif
#if EFFECT == 2
    vec3 rdir = reflect(normalize(x - eye), n);
#endif
#if EFFECT == 3
    vec3 unshadowed = texelFetch(g_albedo, p, 0).rgb / PI * spot_irradiance(light, x, n);
    if (any(greaterThan(unshadowed, vec3(0.0))))
#endif
    for (int s = sample_base; s < min(sample_base + sample_count, spp); ++s) {
        uint rng = sample_stream(pix, seed, uint(s));
        float u0 = pcg_uniform(rng), u1 = pcg_uniform(rng);
#if EFFECT == 1
        vec3 d = cosine_direction(n, u0, u1);
        LdiHit hit = ldi_trace(o, d, n, LDI_INF);
        if (hit.node != LS_END) acc.rgb += hit_radiance(o, d, hit);
#elif EFFECT == 2
        vec3 d = phong_direction(rdir, exponent, u0, u1);
        float c = dot(d, n);
        if (c <= 0.0) continue;
        LdiHit hit = ldi_trace(o, d, n, LDI_INF);
        if (hit.node != LS_END) acc.rgb += (exponent + 2.0) / (exponent + 1.0) * c * hit_radiance(o, d, hit);
#else
        vec3 y = sphere_point(light.position, light_radius, u0, u1);
        vec3 d = y - o;
        float dist = length(d);
        d /= max(dist, 1e-30);
        if (dot(n, d) < 0.0) continue;                          // into the surface: blocked
        LdiHit hit = ldi_trace(o, d, n, dist * (1.0 - shadow_eps));
        if (hit.node == LS_END) acc.r += 1.0;                   // visible samples
#endif
#if defined(LDI_STATS)
        st += uvec4(hit.crossings, 0u, hit.ended ? 1u : 0u, 1u);
        st.y = max(st.y, hit.crossings);
#endif
    }
#if defined(LDI_STATS)
    ldi_stats[pix] = st;
#endif
    if (sample_base + sample_count >= spp) {                     // the last dispatch: the pixel's value
#if EFFECT == 3
        acc = vec4(unshadowed * (acc.r / float(spp)), 1.0);
#elif EFFECT == 2
        acc = vec4(acc.rgb * texelFetch(g_albedo, p, 0).rgb / float(spp), 1.0);
#else
        acc = vec4(acc.rgb / float(spp), 1.0);
#endif
    }
    imageStore(out_image, p, acc);
}
