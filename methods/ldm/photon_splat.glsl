// Photon splatting (aalund2015 §4.2 "Photon Splatting", eq. 4-7): every stored photon adds
//   L(x) += f_s(x) E_p pi K(|M_p (x - x_p)|) = albedo(x) E_p K(|M_p (x - x_p)|),   E_p = Phi_p / A_p,
// A_p = pi/4 |D_u x * D_v x| (the ellipse inscribed in the differential parallelogram), x = the camera
// G-buffer position of the pixel. The differentials are first multiplied by `footprint_scale`.
//
// Raster variant (the paper's): the photon buffer is the vertex buffer, drawn as points; vertex shader =
// irradiance and filter matrix, geometry shader = the parallelogram as a quad (dropped when a corner is
// behind the eye or its screen rectangle's diagonal exceeds max_splat_px), fragment shader = kernel;
// additive blending into an RGBA32F target.
// COMPUTE_SHADER, SPLAT_ATOMIC: one invocation per photon loops over the pixels of the same quad and adds
// with float atomics (GL_NV_shader_atomic_float) into 3 floats per pixel (binding 15).
// COMPUTE_SHADER, SPLAT_STATS: untimed statistics: splats clipped (count, power) into binding 16.
#if defined(COMPUTE_SHADER)
#extension GL_NV_shader_atomic_float : require
#endif
#include "photon.glsl"

uniform mat4 view_proj;
uniform vec2 image_size;
uniform float footprint_scale;
uniform float topology;
uniform float max_splat_px;

#if defined(VERTEX_SHADER)
in vec4 p_x;
in vec4 p_du;
in vec4 p_dv;
in vec4 p_n;
out Splat { vec3 x; vec3 du; vec3 dv; vec3 E; mat3 M; } vs;
void main() {
    vs.x = p_x.xyz;
    vs.du = p_du.xyz * footprint_scale;
    vs.dv = p_dv.xyz * footprint_scale;
    vec3 flux = vec3(p_x.w, p_du.w, p_dv.w);
    vs.E = flux / (0.25 * 3.14159265358979323846 * length(cross(vs.du, vs.dv)));   // eq. (4)
    vs.M = filter_matrix(vs.du, vs.dv, normalize(p_n.xyz), topology);              // eq. (7)
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}

#elif defined(GEOMETRY_SHADER)
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
in Splat { vec3 x; vec3 du; vec3 dv; vec3 E; mat3 M; } vs[];
flat out vec3 f_x;
flat out vec3 f_E;
flat out mat3 f_M;
void main() {
    vec4 c[4];
    vec2 lo, hi;
    if (!splat_corners(vs[0].x, vs[0].du, vs[0].dv, view_proj, image_size, max_splat_px, c, lo, hi)) return;
    for (int i = 0; i < 4; ++i) {
        f_x = vs[0].x;
        f_E = vs[0].E;
        f_M = vs[0].M;
        gl_Position = c[i];
        EmitVertex();
    }
    EndPrimitive();
}

#elif defined(FRAGMENT_SHADER)
uniform sampler2D g_position;
uniform sampler2D g_albedo;
flat in vec3 f_x;
flat in vec3 f_E;
flat in mat3 f_M;
layout(location = 0) out vec4 out_radiance;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 g = texelFetch(g_position, p, 0);
    if (g.w < 0.5) discard;
    float k = silverman(length(f_M * (g.xyz - f_x)));
    if (k <= 0.0) discard;
    out_radiance = vec4(texelFetch(g_albedo, p, 0).rgb * f_E * k, 0.0);   // eq. (5), f_s = albedo / pi
}

#elif defined(COMPUTE_SHADER)
layout(local_size_x = 64) in;
layout(std430, binding = 13) readonly buffer Photons { Photon photons[]; };
uniform uint n_photons;
#if defined(SPLAT_STATS)
layout(std430, binding = 16) buffer SplatStats { uint st_count[16]; float st_power[16]; };
#else
layout(std430, binding = 15) buffer Accum { float accum[]; };   // 3 floats per pixel, rows bottom-up
uniform sampler2D g_position;
uniform sampler2D g_albedo;
float edge(vec2 a, vec2 b, vec2 p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); }
#endif
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= n_photons) return;
    vec3 x = photons[i].x_r.xyz;
    vec3 du = photons[i].du_g.xyz * footprint_scale, dv = photons[i].dv_b.xyz * footprint_scale;
    vec3 flux = vec3(photons[i].x_r.w, photons[i].du_g.w, photons[i].dv_b.w);
    vec4 c[4];
    vec2 lo, hi;
    bool drawn = splat_corners(x, du, dv, view_proj, image_size, max_splat_px, c, lo, hi);
#if defined(SPLAT_STATS)
    if (!drawn) {
        atomicAdd(st_count[0], 1u);
        atomicAdd(st_power[0], (flux.x + flux.y + flux.z) * (1.0 / 3.0));
    }
#else
    if (!drawn) return;
    vec3 E = flux / (0.25 * 3.14159265358979323846 * length(cross(du, dv)));
    mat3 M = filter_matrix(du, dv, normalize(photons[i].n_id.xyz), topology);
    vec2 q[4];
    for (int j = 0; j < 4; ++j) q[j] = (c[j].xy / c[j].w * 0.5 + 0.5) * image_size;
    float orient = sign(edge(q[0], q[1], q[3]));   // quad q0 -> q1 -> q3 -> q2 is convex
    ivec2 a = max(ivec2(floor(lo)), ivec2(0)), b = min(ivec2(ceil(hi)), ivec2(image_size));
    for (int py = a.y; py < b.y; ++py) {
        for (int px = a.x; px < b.x; ++px) {
            vec2 pc = vec2(px, py) + 0.5;   // pixel centre, as the rasterizer samples it
            if (orient * edge(q[0], q[1], pc) < 0.0 || orient * edge(q[1], q[3], pc) < 0.0 ||
                orient * edge(q[3], q[2], pc) < 0.0 || orient * edge(q[2], q[0], pc) < 0.0) continue;
            vec4 g = texelFetch(g_position, ivec2(px, py), 0);
            if (g.w < 0.5) continue;
            float k = silverman(length(M * (g.xyz - x)));
            if (k <= 0.0) continue;
            vec3 L = texelFetch(g_albedo, ivec2(px, py), 0).rgb * E * k;
            uint o = 3u * uint(py * int(image_size.x) + px);
            atomicAdd(accum[o], L.r);
            atomicAdd(accum[o + 1u], L.g);
            atomicAdd(accum[o + 2u], L.b);
        }
    }
#endif
}
#endif
