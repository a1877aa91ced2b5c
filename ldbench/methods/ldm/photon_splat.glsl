// Photon splatting (aalund2015 §4.2 "Photon Splatting", eq. 4-7): every stored photon adds
//   L(x) += f_s(x) E_p pi K(|M_p (x - x_p)|) = albedo(x) E_p K(|M_p (x - x_p)|),   E_p = Phi_p / A_p,
// A_p = pi/4 |D_u x * D_v x| (the ellipse inscribed in the differential parallelogram), x = the camera
// G-buffer position of the pixel. The differentials are first multiplied by `footprint_scale`.
//
// Raster variant (the paper's): the photon buffer is the vertex buffer, drawn as points; vertex shader =
// irradiance and filter matrix, geometry shader = the parallelogram as a quad (dropped when a corner is
// behind the eye or its screen rectangle's diagonal exceeds max_splat_px), fragment shader = kernel;
// additive blending into an RGBA32F target.
// COMPUTE_SHADER, SPLAT_ATOMIC: one workgroup per photon loops over the pixels of the same quad and adds
// with float atomics (GL_NV_shader_atomic_float) into 3 floats per pixel (B_PHOTON_ACCUM).
// COMPUTE_SHADER, SPLAT_STATS: untimed statistics into B_PHOTON_STATS: splats clipped (count, power) and the
// drawn splats' screen area (about the fragments shaded).
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
in vec3 p_n;
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
layout(std430, binding = B_PHOTONS) readonly buffer Photons { Photon photons[]; };
uniform uint n_photons;
#if defined(SPLAT_STATS)
layout(std430, binding = B_PHOTON_STATS) buffer SplatStats { uint st_count[16]; float st_power[16]; };
void main() {   // one invocation per photon (grid-stride)
    for (uint i = gl_GlobalInvocationID.x; i < n_photons; i += gl_NumWorkGroups.x * 64u) {
        vec3 du = photons[i].du_g.xyz * footprint_scale, dv = photons[i].dv_b.xyz * footprint_scale;
        vec3 flux = vec3(photons[i].x_r.w, photons[i].du_g.w, photons[i].dv_b.w);
        vec4 c[4];
        vec2 lo, hi;
        if (!splat_corners(photons[i].x_r.xyz, du, dv, view_proj, image_size, max_splat_px, c, lo, hi)) {
            atomicAdd(st_count[0], 1u);
            atomicAdd(st_power[0], (flux.x + flux.y + flux.z) * (1.0 / 3.0));
            continue;
        }
        // the projected quad's area in pixels (shoelace over q0 q1 q3 q2), clipped to the image by its
        // bounding rectangle's overlap fraction: about the fragments the raster path shades
        vec2 q[4];
        for (int j = 0; j < 4; ++j) q[j] = (c[j].xy / c[j].w * 0.5 + 0.5) * image_size;
        float area = 0.5 * abs((q[0].x * q[1].y - q[1].x * q[0].y) + (q[1].x * q[3].y - q[3].x * q[1].y) +
                               (q[3].x * q[2].y - q[2].x * q[3].y) + (q[2].x * q[0].y - q[0].x * q[2].y));
        vec2 s = max(hi - lo, vec2(1e-6));
        vec2 o = max(min(hi, image_size) - max(lo, vec2(0.0)), vec2(0.0));
        atomicAdd(st_power[1], area * (o.x * o.y) / (s.x * s.y));
    }
}
#else
// One workgroup per photon (grid-stride over photons), its 64 invocations stride over the pixels of the
// splat's screen rectangle: a 400-pixel splat is not left to one thread. The pixels the raster path
// shades: the quad as the geometry shader's strip, triangles (q0, q1, q2) and (q2, q1, q3), covered by the
// hardware's rule (layered/fill_rule.glsl), each shared-edge centre once, samples beyond the near or far plane
// dropped as clipping would; so the two paths differ by the order of their sums (and at a pixel where the
// GPU's own viewport transform rounds a corner across a sub-pixel step: tests/test_ldm_indirect.py).
#include "layered/fill_rule.glsl"
layout(std430, binding = B_PHOTON_ACCUM) buffer Accum { float accum[]; };   // 3 floats per pixel, rows bottom-up
uniform sampler2D g_position;
uniform sampler2D g_albedo;
// z_ndc at window point p on the plane through (w_i, z_i): affine in window space
float plane_z(vec2 w0, vec2 w1, vec2 w2, vec3 z, vec2 p) {
    return z.x + dot(sp_plane_gradient(w0, w1, w2, z.x, z.y, z.z), p - w0);
}
void main() {
    for (uint i = gl_WorkGroupID.x; i < n_photons; i += gl_NumWorkGroups.x) {
        vec3 x = photons[i].x_r.xyz;
        vec3 du = photons[i].du_g.xyz * footprint_scale, dv = photons[i].dv_b.xyz * footprint_scale;
        vec3 flux = vec3(photons[i].x_r.w, photons[i].du_g.w, photons[i].dv_b.w);
        vec4 c[4];
        vec2 lo, hi;
        if (!splat_corners(x, du, dv, view_proj, image_size, max_splat_px, c, lo, hi)) continue;
        vec3 E = flux / (0.25 * 3.14159265358979323846 * length(cross(du, dv)));
        mat3 M = filter_matrix(du, dv, normalize(photons[i].n), topology);
        vec2 q[4];
        vec4 z;
        for (int j = 0; j < 4; ++j) {
            q[j] = (c[j].xy / c[j].w * 0.5 + 0.5) * image_size;
            z[j] = c[j].z / c[j].w;
        }
        ivec2 size = ivec2(image_size);
        FrTri ta = fr_setup(q[0], q[1], q[2], size), tb = fr_setup(q[2], q[1], q[3], size);
        bool clip = any(greaterThan(abs(z), vec4(1.0)));
        ivec2 a = min(ta.lo, tb.lo), b = max(ta.hi, tb.hi) + 1;   // each box clamped to the image
        int w = b.x - a.x, n = w * (b.y - a.y);
        for (int j = int(gl_LocalInvocationID.x); j < n && w > 0; j += 64) {
            int px = a.x + j % w, py = a.y + j / w;
            bool in_a = fr_covers(ta, ivec2(px, py));
            if (!in_a && !fr_covers(tb, ivec2(px, py))) continue;
            if (clip && abs(in_a ? plane_z(q[0], q[1], q[2], z.xyz, vec2(px, py) + 0.5)
                                 : plane_z(q[2], q[1], q[3], z.zyw, vec2(px, py) + 0.5)) > 1.0) continue;
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
}
#endif
#endif
