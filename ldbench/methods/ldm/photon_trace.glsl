// Photon tracing through the LDMs (aalund2015 §4.2 "Photon Tracing"): one invocation per texel of the
// R x R light raster (the spot light's G-buffer: first hits x1, normals facing the light, albedo).
//
//   1. flux:   Phi_p = I * falloff(d) * Omega_texel (Omega = the texel's exact solid angle), so the
//              photons of the raster carry the spot's whole flux (sum = Phi_light up to the falloff's
//              midpoint rule)
//   2. init:   ray differential of the light's pinhole through the texel centre, per texel (Igehy)
//   3. transfer to x1 (d1 = d0)
//   4. split into the N directions sigma_k v_k of the maps that lie in n1's hemisphere (2N candidates,
//      the other N have cos <= 0 and zero weight), weight albedo1 * w_k with
//      w_k = cos_k / sum_j cos_j (estimator 0, "ratio": exactly energy-conserving) or
//      w_k = 2 cos_k / N (estimator 1, "paper": the equal-area quadrature of (albedo/pi) cos dOmega);
//      a. x2 = trace(x1, d2) with the LDM two-way query (ldm_trace.glsl)
//      b. project x2 into the camera; discard it unless the G-buffer pixel shows x2's surface (x2 within
//         vis_tol of the pixel's tangent plane) from the side the photon arrives on; REFINE_HIT = 1: move x2
//         along d2 onto that plane
//      c. diffuse reflection of the directional differential: rotated by alpha(w_i, d2), the quaternion
//         taking w_i to d2, with ROTATE_INCIDENT = 1: w_i = -d1 (the author's engine; with the fixed
//         sign flip of the reversed direction this is a mirror reflection, det -1), else w_i = d1 (a proper
//         rotation, det +1, which turns one axis of a diverging beam into a converging one: line foci)
//      d. transfer the differential to x2's tangent plane; drop a photon whose positional differential
//         has a component above diff_max (the differential bias)
//      e. store (B_PHOTONS), counting with one atomicAdd; beyond `capacity` photons are counted, not stored
// PHOTON_STATS: an untimed statistics variant that stores nothing and adds every candidate's count and
// power (mean of RGB) to the counters of its fate (B_PHOTON_STATS, float atomics).
#if defined(PHOTON_STATS)
#extension GL_NV_shader_atomic_float : require
#endif
#include "common/common.glsl"
#include "ldm_trace.glsl"
#include "photon.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D l_position;   // light raster: position (w = hit)
uniform sampler2D l_normal;     // normal facing the light
uniform sampler2D l_albedo;
uniform sampler2D c_position;   // camera G-buffer
uniform sampler2D c_normal;     // normal facing the camera
uniform SpotLight light;
uniform vec3 light_right, light_up, light_fwd;
uniform float light_tan;        // tan(half field of view) of the light raster
uniform int photons_side;       // R
uniform mat4 view_proj;
uniform ivec2 image_size;
uniform uint n_maps;
uniform float bias;             // LDM self-intersection bias, world units
uniform float vis_tol;          // world units
uniform float diff_max;         // world units
uniform int estimator;          // 0 ratio, 1 paper
uniform uint capacity;

#if defined(PHOTON_STATS)
// counts[i] / power[i] by fate (ldbench/methods/ldm/indirect.py FATES), summed per invocation first (fewer
// float atomics, less rounding), added to B_PHOTON_STATS at the end
#define N_FATES 10
layout(std430, binding = B_PHOTON_STATS) buffer PhotonStats { uint st_count[16]; float st_power[16]; };
uint f_count[N_FATES];
float f_power[N_FATES];
void fate(uint i, float p) { f_count[i] += 1u; f_power[i] += p; }
void flush_fates() {
    for (uint i = 0u; i < uint(N_FATES); ++i) {
        if (f_count[i] == 0u) continue;
        atomicAdd(st_count[i], f_count[i]);
        atomicAdd(st_power[i], f_power[i]);
    }
}
#else
layout(std430, binding = B_PHOTONS) writeonly buffer Photons { Photon photons[]; };
layout(std430, binding = B_PHOTON_COUNT) buffer PhotonCount { uint photon_count; };
#endif

float mean3(vec3 v) { return (v.x + v.y + v.z) * (1.0 / 3.0); }

// Solid angle of the image-plane rectangle [x0, x1] x [y0, y1] at unit distance from the pinhole.
float rect_solid_angle(vec2 a, vec2 b) {
    vec4 x = vec4(a.x, b.x, a.x, b.x), y = vec4(a.y, a.y, b.y, b.y);
    vec4 f = atan(x * y / sqrt(1.0 + x * x + y * y));
    return f.w - f.y - f.z + f.x;
}

void trace_texel(ivec2 p);

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= photons_side || p.y >= photons_side) return;
#if defined(PHOTON_STATS)
    for (int i = 0; i < N_FATES; ++i) { f_count[i] = 0u; f_power[i] = 0.0; }
    trace_texel(p);
    flush_fates();
#else
    trace_texel(p);
#endif
}

void trace_texel(ivec2 p) {
    float step_ = 2.0 * light_tan / float(photons_side);       // texel size on the unit image plane
    vec2 s = (vec2(p) + 0.5) * step_ - light_tan;               // texel centre
    vec3 dh = light_fwd + s.x * light_right + s.y * light_up;   // unnormalised direction
    vec3 flux = light.intensity * spot_falloff(light, dh) * rect_solid_angle(s - 0.5 * step_, s + 0.5 * step_);
    if (mean3(flux) <= 0.0) return;                             // outside the cone: no photon
#if defined(PHOTON_STATS)
    fate(0u, mean3(flux));
#endif
    vec4 pos = texelFetch(l_position, p, 0);
    if (pos.w < 0.5) return;                                    // leaves the scene at once
    vec3 x1 = pos.xyz;
    vec3 n1 = normalize(texelFetch(l_normal, p, 0).xyz);
    vec3 alb1 = texelFetch(l_albedo, p, 0).rgb;
    vec3 d1 = normalize(x1 - light.position);
    float dh2 = dot(dh, dh);
    // Igehy: D(d/|d|) = (|d|^2 D d - (d . D d) d) / |d|^3 with D d = step * right (u) or step * up (v)
    vec3 ddu = (dh2 * light_right - dot(dh, light_right) * dh) * (step_ / (dh2 * sqrt(dh2)));
    vec3 ddv = (dh2 * light_up - dot(dh, light_up) * dh) * (step_ / (dh2 * sqrt(dh2)));
    vec3 dx1u = vec3(0.0), dx1v = vec3(0.0);
    transfer(dx1u, dx1v, ddu, ddv, d1, n1, distance(x1, light.position));
#if defined(PHOTON_STATS)
    fate(1u, mean3(flux));
    fate(9u, mean3(flux * alb1));
#endif
    float sum_c = 0.0;
    for (uint k = 0u; k < n_maps; ++k) {
        float c = abs(dot(n1, ol_axes[k].v.xyz));
        if (c > 1e-6) sum_c += c;
    }
    uint texel = uint(p.y * photons_side + p.x);
    for (uint k = 0u; k < n_maps; ++k) {
        float c = dot(n1, ol_axes[k].v.xyz);
        if (abs(c) <= 1e-6) continue;
        float sigma = c > 0.0 ? 1.0 : -1.0;
        vec3 d2 = sigma * ol_axes[k].v.xyz;
        float w = estimator == 0 ? abs(c) / sum_c : 2.0 * abs(c) / float(n_maps);
        vec3 flux2 = flux * alb1 * w;
#if defined(PHOTON_STATS)
        float pw = mean3(flux2);
        fate(2u, pw);
#endif
        // a. second hit
        float t2 = ldm_trace(k, sigma, x1, n1, bias);
        if (t2 < 0.0) {
#if defined(PHOTON_STATS)
            fate(6u, pw);
#endif
            continue;
        }
        vec3 x2 = x1 + t2 * d2;
        // b. the camera must see x2
        vec4 cp = view_proj * vec4(x2, 1.0);
        vec2 ndc = cp.xy / cp.w;
        if (cp.w <= 0.0 || any(greaterThan(abs(ndc), vec2(1.0)))) {
#if defined(PHOTON_STATS)
            fate(4u, pw);
#endif
            continue;
        }
        ivec2 px = clamp(ivec2((ndc * 0.5 + 0.5) * vec2(image_size)), ivec2(0), image_size - 1);
        vec4 g = texelFetch(c_position, px, 0);
        vec3 n2 = normalize(texelFetch(c_normal, px, 0).xyz);
        if (g.w < 0.5 || abs(dot(x2 - g.xyz, n2)) > vis_tol || dot(n2, d2) >= 0.0) {
#if defined(PHOTON_STATS)
            fate(5u, pw);
#endif
            continue;
        }
#if REFINE_HIT
        // x2 along d2 onto the tangent plane of the pixel that sees it: the map gives the depth of its
        // texel centre's column, off x1's column by up to half a texel (docs/reference/methods/ldm_indirect.md)
        t2 -= dot(x2 - g.xyz, n2) / dot(d2, n2);
        x2 = x1 + t2 * d2;
#endif
        // c. diffuse reflection of the differential, d. transfer to x2
#if ROTATE_INCIDENT
        vec4 q = quat_between(-d1, d2);   // w_i = -d1, pointing back to the light (the author's engine)
#else
        vec4 q = quat_between(d1, d2);    // w_i = d1: d* = alpha d alpha-bar takes d1 to d2
#endif
        vec3 du = dx1u, dv = dx1v;
        transfer(du, dv, quat_rotate(q, ddu), quat_rotate(q, ddv), d2, n2, t2);
        float m = max(max(max(abs(du.x), abs(du.y)), abs(du.z)), max(max(abs(dv.x), abs(dv.y)), abs(dv.z)));
        if (!(m <= diff_max)) {   // also NaN
#if defined(PHOTON_STATS)
            fate(7u, pw);
#endif
            continue;
        }
#if defined(PHOTON_STATS)
        fate(3u, pw);
#else
        // e. store
        uint i = atomicAdd(photon_count, 1u);
        if (i < capacity) {
            photons[i].x_r = vec4(x2, flux2.r);
            photons[i].du_g = vec4(du, flux2.g);
            photons[i].dv_b = vec4(dv, flux2.b);
            photons[i].n = n2;
            photons[i].id = texel * n_maps + k;
        }
#endif
    }
}
