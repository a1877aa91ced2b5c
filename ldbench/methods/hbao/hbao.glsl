// Horizon-based ambient occlusion (Bavoil, Sainz, Dimitrov 2008) on the shared G-buffer.
//
// One invocation per pixel. For each of `directions` screen-space directions (rotated per pixel by a
// 4x4 tiled random texture), march `steps` pixels out to the projected radius of d_max (clamped to
// max_radius_px and to the image border), with a jittered start, and track the horizon: the highest
// sample S (seen from P) within 3D distance d_max.
//
// INTEGRAL == 0 ("hbao", the 2008 formula): elevations are measured from the image plane (view-space
//   z is the zenith); per direction  occ = sum_k W(r_k) (sin h_k - sin h_{k-1}),  h_0 = t + bias
//   (t = tangent angle from the normal), i.e. per-sample attenuation; AO = 1 - mean(occ).
// INTEGRAL == 1 ("cosine"): the slice through the eye, P and the screen direction (exact: every pixel
//   on that screen line lies in that plane) is parameterized by the angle theta from the view vector
//   v = normalize(-P) towards the direction; with the normal projected into the slice (length |n_p|,
//   angle gamma from v), the cosine-weighted measure of the directions between v and theta is
//       F(theta) = 1/4 (-cos(2 theta - gamma) + cos gamma + 2 theta sin gamma)
//   (Jimenez et al. 2016, GTAO's inner integral); dF/dtheta = sin(theta) cos(theta - gamma). One side
//   of a slice is unoccluded down to the tangent plane theta_t = gamma + pi/2; each sample raising the
//   horizon from theta_prev to theta_k removes rho(r_k) (F(theta_prev) - F(theta_k)). Each direction is
//   one half-slice: A = 1/pi * int_0^{2pi} |n_p| F_vis dphi, estimated as the ratio
//   sum_i |n_p| F_vis / sum_i |n_p| F(theta_t): the denominator's mean over directions is exactly 1/2
//   (its integral over phi is pi: the unoccluded hemisphere), and the ratio makes an unoccluded pixel exactly 1 for any number of
//   directions (the plain mean 2/N sum |n_p| F_vis scatters around 1 on surfaces seen at grazing
//   angles, and clamping to [0, 1] would then bias it low).
//   For rho = 1 this is exactly 1/pi * int V cos dw over the normal's hemisphere as seen in the depth
//   buffer (one layer, nothing behind the first surface, nothing off screen).
//
// Falloff (the `ao` effect): FALLOFF_MODE 0 = step (rho = 1 for r < d_max), 1 = quadratic
// (rho = 1 - (r/d_max)^2), 2 = unbounded (d_max = inf; rho = 1). Samples with r >= d_max are ignored.
// Sampling (`sampling`): 0 = fixed, min(steps, radius) samples per direction spread over the radius
// (the sample count does not grow with d_max); 1 = pixel_step, one sample every ~step_px pixels out to
// the radius, min(steps, radius / step_px) of them (NVIDIA's HBAO sample: the cost grows with the
// projected radius of d_max).
// Output: r = AO (1 = unoccluded; 1 on background); with COUNT_STEPS, r = the samples marched per pixel
// (sum over directions), 0 where none; with GROUP_IDS, r = the index of the workgroup that ran the pixel.
// DEINTERLEAVED 1 (`access = "deinterleaved"`): the same arithmetic on the same values in another order.
//   deinterleave.glsl has copied the view-space depths and normals into 4x4 layers of a quarter of the
//   image each (layers.glsl), layer (q & 3) holding pixel q at q >> 2, and invocation g here is pixel
//   4 (g mod quarter) + g / quarter: every workgroup lies in one layer, so its pixels share p & 3 and thus
//   the rotation and jitter, and a sample offset that is the same for all of them reads neighbouring texels
//   of one layer (rather than 16 rotations scattering the group's reads over a circle of the radius).
#include "common/common.glsl"

#ifndef INTEGRAL
#define INTEGRAL 1
#endif
#ifndef PLANE_FIT
#define PLANE_FIT 1
#endif
#ifndef COUNT_STEPS
#define COUNT_STEPS 0
#endif
#ifndef DEINTERLEAVED
#define DEINTERLEAVED 0
#endif
#ifndef GROUP_IDS
#define GROUP_IDS 0
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D g_position;   // world position, w = 1 where hit
uniform sampler2D g_normal;     // camera-facing geometric normal (world)
uniform sampler2D noise;        // 4x4: r = rotation in [0,1), g = start jitter in [0,1)
uniform mat4 view;              // world -> view (rigid)
uniform float focal_px;         // pixels per world unit at unit view depth: 0.5 H / tan(fov_y / 2)
uniform vec2 half_size;         // (W/2, H/2): the principal point in pixels
uniform float d_max;            // world units (ignored for FALLOFF_MODE 2)
uniform int falloff_mode;       // 0 step, 1 quadratic, 2 unbounded
uniform float max_radius_px;
uniform int directions;
uniform int steps;              // samples per direction (fixed) or their cap (pixel_step)
uniform int sampling;           // 0 fixed, 1 pixel_step
uniform float step_px;          // pixel_step: pixels between samples
uniform float angle_bias;       // radians
uniform float cos_bias;         // cos(angle_bias), sin(angle_bias)
uniform float sin_bias;
// A surface point is its pixel centre's view ray at the view-space depth z: one float a sample reads instead
// of three (the G-buffer's position is that ray's hit, so the two agree to float rounding).
vec3 view_point(ivec2 q, float z) { return vec3((vec2(q) + 0.5 - half_size) / focal_px, -1.0) * -z; }

#if DEINTERLEAVED
#include "layers.glsl"

bool surface(ivec2 q, out vec3 S, out vec3 n) {   // false where no surface (background)
    vec4 t = layers[layer_index(q)];
    S = view_point(q, t.w);
    n = t.xyz;
    return t.w < 0.0;
}
#else
bool surface(ivec2 q, out vec3 S, out vec3 n) {   // false where no surface (background)
    vec4 s = texelFetch(g_position, q, 0);
    S = view_point(q, (view * vec4(s.xyz, 1.0)).z);
    n = mat3(view) * texelFetch(g_normal, q, 0).xyz;
    return s.w >= 0.5;
}
#endif

float rho(float r2) {           // obscurance weight of an occluder at squared distance r2 (< d_max^2)
    if (falloff_mode == 1) return 1.0 - r2 / (d_max * d_max);
    return 1.0;
}

float F(float theta, float gamma) {
    return 0.25 * (-cos(2.0 * theta - gamma) + cos(gamma) + 2.0 * theta * sin(gamma));
}

void main() {
#if DEINTERLEAVED
    ivec2 g = ivec2(gl_GlobalInvocationID.xy);
    ivec2 cell = g / quarter;
    ivec2 p = 4 * (g - cell * quarter) + cell;
    if (any(greaterThanEqual(cell, ivec2(4)))) return;
#else
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
#endif
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
#if GROUP_IDS   // tests: the workgroup that computes pixel p (the access pattern)
    imageStore(out_ao, p, vec4(float(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x)));
    return;
#endif
    vec3 P;
    vec3 n;
    if (!surface(p, P, n)) { imageStore(out_ao, p, vec4(COUNT_STEPS == 1 ? 0.0 : 1.0)); return; }
    n = normalize(n);
    float depth = -P.z;
    float radius = (falloff_mode == 2) ? max_radius_px : min(d_max * focal_px / depth, max_radius_px);
    if (radius < 1.0) { imageStore(out_ao, p, vec4(COUNT_STEPS == 1 ? 0.0 : 1.0)); return; }
    float d2max = (falloff_mode == 2) ? 3.0e38 : d_max * d_max;

    vec2 rnd = texelFetch(noise, p & 3, 0).rg;
    vec2 pc = vec2(p) + 0.5;
    vec3 v = normalize(-P);
    float sum = 0.0, sum_full = 0.0;
    int n_samples = 0;
    for (int i = 0; i < directions; ++i) {
        float phi = 2.0 * PI * (float(i) + rnd.x) / float(directions);
        vec2 dir = vec2(cos(phi), sin(phi));
        // march no farther than the image border: every sample lands on screen
        vec2 room = mix(pc, vec2(size) - pc, step(0.0, dir)) / max(abs(dir), vec2(1e-6));
        float radius_i = min(radius, min(room.x, room.y));
        int ns = sampling == 1 ? min(steps, int(radius_i / step_px))   // one sample per step_px pixels
                               : min(steps, int(radius_i));             // no more steps than pixels
        float dq = radius_i / float(ns + 1);
        n_samples += ns;
        // The slice: the plane through the eye, P and the screen direction (every pixel on the screen
        // line from p along dir lies in it). v = towards the eye, o = in-slice direction orthogonal
        // to v on the marching side; the normal projected into the slice has length nlen, angle gamma.
        vec3 d3 = vec3(dir, 0.0);
        vec3 o = normalize(d3 - dot(d3, v) * v);
        float nv = max(dot(n, v), 0.0), no = dot(n, o);
#if INTEGRAL == 0
        // tangent angle t: elevation above the image plane (view-space z towards the eye) of the
        // surface tangent whose projection points along dir (the 2008 implementation's T from the
        // depth derivatives), i.e. T = cos(theta_t) v + sin(theta_t) o with theta_t = gamma + pi/2 (below):
        // sin t = cos(gamma) o.z - sin(gamma) v.z, and the horizon starts at
        // sin(min(t + bias, pi/2)) = sin t cos(bias) + cos t sin(bias), or 1 where sin t >= cos(bias).
        float nvc = max(nv, 1e-6), hyp = sqrt(nvc * nvc + no * no);
        float sin_t = clamp((nvc * o.z - no * v.z) / hyp, -1.0, 1.0);
        float sin_h = sin_t >= cos_bias ? 1.0 : sin_t * cos_bias + sqrt(1.0 - sin_t * sin_t) * sin_bias;
        float occ = 0.0;
#else
        float nlen = sqrt(nv * nv + no * no);
        float gamma = atan(no, max(nv, 1e-6));        // in [-pi/2, pi/2]
        float theta_t = gamma + 0.5 * PI;             // the tangent plane, as an angle from v
        float theta_h = max(theta_t - angle_bias, 0.0);
        float f_h = F(theta_h, gamma);
        float occ = 0.0;
#endif
        for (int k = 0; k < ns; ++k) {
            vec2 q = pc + dir * (dq * (float(k) + rnd.y) + dq);
            ivec2 qi = ivec2(floor(q));
            if (any(lessThan(qi, ivec2(0))) || any(greaterThanEqual(qi, size))) break;
            vec3 S, n_s;
            if (!surface(qi, S, n_s) || qi == p) continue;
#if PLANE_FIT
            // The pixel's surface point lies on the ray through its centre, up to 0.7 px off the
            // marching line, hence off the slice; on sloped surfaces that reads as false occlusion.
            // Move it along its own tangent plane to the view ray through the exact sample point q.
            vec3 ray = vec3((q - half_size) / focal_px, -1.0);
            float denom = dot(ray, n_s);
            if (denom < 0.0 && denom * denom > 1e-8 * dot(ray, ray)) {   // not grazing: denom < -1e-4 |ray|
                vec3 S2 = ray * (dot(S, n_s) / denom);
                if (abs(S2.z - S.z) < 0.05 * -S.z) S = S2;
            }
#endif
            vec3 D = S - P;
            float r2 = dot(D, D);
            if (r2 >= d2max || r2 <= 0.0) continue;
#if INTEGRAL == 0
            float sin_s = D.z * inversesqrt(r2);
            if (sin_s > sin_h) {
                occ += rho(r2) * (sin_s - sin_h);
                sin_h = sin_s;
            }
#else
            float theta = clamp(atan(max(dot(D, o), 0.0), dot(D, v)), 0.0, PI);
            if (theta < theta_h) {
                float f = F(theta, gamma);
                occ += rho(r2) * (f_h - f);
                theta_h = theta;
                f_h = f;
            }
#endif
        }
#if INTEGRAL == 0
        sum += occ;
#else
        float f_full = F(theta_t, gamma);
        sum += nlen * (f_full - occ);
        sum_full += nlen * f_full;
#endif
    }
#if INTEGRAL == 0
    float ao = 1.0 - sum / float(directions);
#else
    float ao = sum / max(sum_full, 1e-20);
#endif
#if COUNT_STEPS
    imageStore(out_ao, p, vec4(float(n_samples)));
#else
    imageStore(out_ao, p, vec4(clamp(ao, 0.0, 1.0)));
#endif
}
