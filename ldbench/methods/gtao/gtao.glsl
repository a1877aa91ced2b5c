// Ground-truth based ambient occlusion (Jimenez, Wu, Pesce, Jarabo 2016) on the shared G-buffer.
//
// One invocation per pixel. `slices` planes through the eye, P and a screen direction phi in [0, pi)
// (rotated per pixel by a spatial R2 sequence along a 64x64 Hilbert curve); in each, a horizon search
// of `steps` samples on each side out to the projected radius of d_max (clamped to max_radius_px and to
// the image border on that side, so that every sample lands on screen), samples spaced by the power
// `distribution` of their index (denser near P). Angles are measured from the view vector v towards the
// slice direction o; the normal projected into the slice has length nlen and angle gamma. A side's
// horizon is the largest cosine dot(normalize(S - P), v) of its samples, each first pulled towards the
// tangent plane's cosine (the "low horizon") by 1 - w, w = rho(r) * fade(r): rho the ao effect's
// obscurance (step: 1; quadratic: 1 - r^2/d_max^2; nothing at r >= d_max), fade GTAO's linear fall-off
// over the last `falloff_range` of d_max. r is |S - P| with its view-z part stretched by
// 1 + thin_occluder (the thin-occluder heuristic: samples far behind or in front count less).
// The cosine-weighted visibility of the slice between the two horizons h0 <= gamma <= h1 is analytic:
//     V = nlen / 4 * sum_{h in h0, h1} (-cos(2h - gamma) + cos(gamma) + 2 h sin(gamma))
// and AO = (mean over slices of V) ^ final_power.
// FALLOFF_MODE 0 = step, 1 = quadratic, 2 = unbounded (d_max = inf: rho = 1, radius = max_radius_px).
// PREFILTER 0: a sample reads the G-buffer's world position and normal at its pixel and is moved along
//   its tangent plane onto the ray through the exact sample point. PREFILTER 1 (XeGTAO's structure): a
//   sample reads the view-space depth that prefilter.glsl wrote, from MIP level
//   round(log2(offset in px) - mip_offset) clamped to [0, 4] (far samples read the coarser, filtered
//   levels), and its point is the ray through its pixel's centre at that depth. DEPTH16 1: levels 1..4
//   are 16-bit floats (a separate texture, depth_mips16, its level 0 = level 1); level 0 stays 32-bit.
#include "common/common.glsl"

#ifndef PREFILTER
#define PREFILTER 0
#endif
#ifndef DEPTH16
#define DEPTH16 0
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D g_position;   // world position, w = 1 where hit
uniform sampler2D g_normal;     // camera-facing geometric normal (world)
uniform mat4 view;              // world -> view (rigid)
uniform float focal_px;         // pixels per world unit at unit view depth: 0.5 H / tan(fov_y / 2)
uniform vec2 half_size;         // (W/2, H/2): the principal point in pixels
uniform float d_max;
uniform int falloff_mode;
uniform float max_radius_px;
uniform int slices;
uniform int steps;
uniform float distribution;     // sample spacing power
uniform float falloff_range;    // fraction of d_max over which GTAO's fade goes from 1 to 0 (0 = none)
uniform float thin_occluder;
uniform float final_power;
uniform uint noise_offset;
#if PREFILTER
uniform sampler2D depth_mips;   // view-space depth (> 0; 0 = background), levels 0..4 (0..0 with DEPTH16)
#if DEPTH16
uniform sampler2D depth_mips16; // levels 1..4 as its levels 0..3, 16-bit
#endif
uniform float mip_offset;       // XeGTAO's DepthMIPSamplingOffset
#endif

uint hilbert_index(uint x, uint y) {      // position along the 64x64 Hilbert curve
    uint index = 0u;
    for (uint cur = 32u; cur > 0u; cur >>= 1u) {
        uint rx = (x & cur) > 0u ? 1u : 0u;
        uint ry = (y & cur) > 0u ? 1u : 0u;
        index += cur * cur * ((3u * rx) ^ ry);
        if (ry == 0u) {
            if (rx == 1u) { x = 63u - x; y = 63u - y; }
            uint t = x; x = y; y = t;
        }
    }
    return index;
}

float weight(float r) {
    if (falloff_mode == 2) return 1.0;
    if (r >= d_max) return 0.0;
    float rho = (falloff_mode == 1) ? 1.0 - (r * r) / (d_max * d_max) : 1.0;
    float fade = falloff_range > 0.0 ? clamp((d_max - r) / (falloff_range * d_max), 0.0, 1.0) : 1.0;
    return rho * fade;
}

float arc(float h, float gamma) {
    return -cos(2.0 * h - gamma) + cos(gamma) + 2.0 * h * sin(gamma);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    if (pos.w < 0.5) { imageStore(out_ao, p, vec4(1.0)); return; }

    vec3 P = (view * vec4(pos.xyz, 1.0)).xyz;
    vec3 n = normalize(mat3(view) * texelFetch(g_normal, p, 0).xyz);
    float radius = (falloff_mode == 2) ? max_radius_px : min(d_max * focal_px / -P.z, max_radius_px);
    if (radius < 1.0) { imageStore(out_ao, p, vec4(1.0)); return; }

    uint idx = hilbert_index(uint(p.x) & 63u, uint(p.y) & 63u) + noise_offset;
    vec2 rnd = fract(0.5 + float(idx) * vec2(0.75487766624669276, 0.56984029099805327));
    vec2 pc = vec2(p) + 0.5;
    vec3 v = normalize(-P);
    float visibility = 0.0;
    for (int s = 0; s < slices; ++s) {
        float phi = PI * (float(s) + rnd.x) / float(slices);
        vec2 dir = vec2(cos(phi), sin(phi));
        vec3 d3 = vec3(dir, 0.0);
        vec3 o = normalize(d3 - dot(d3, v) * v);
        float nv = dot(n, v), no = dot(n, o);
        float nlen = sqrt(nv * nv + no * no);
        float gamma = atan(no, max(nv, 1e-6));          // in [-pi/2, pi/2]
        // side +1 along o, side -1 against it; horizon cosines start at the tangent plane's
        float low_pos = cos(gamma + 0.5 * PI), low_neg = cos(gamma - 0.5 * PI);
        float hc_pos = low_pos, hc_neg = low_neg;
        for (int side = 0; side < 2; ++side) {
            float sgn = side == 0 ? 1.0 : -1.0;
            float low = side == 0 ? low_pos : low_neg;
            float hc = low;
            // march no farther than the image border on this side: every sample lands on screen
            vec2 sd = sgn * dir;
            vec2 room = mix(pc, vec2(size) - pc, step(0.0, sd)) / max(abs(sd), vec2(1e-6));
            float radius_side = min(radius, min(room.x, room.y));
            for (int k = 0; k < steps && radius_side >= 1.0; ++k) {
                float t = pow((float(k) + rnd.y) / float(steps), distribution);
                float offset = mix(1.0, radius_side, t);
                vec2 q = pc + sd * offset;
                ivec2 qi = clamp(ivec2(floor(q)), ivec2(0), size - 1);
                if (qi == p) continue;
#if PREFILTER
                int lod = int(clamp(floor(log2(offset) - mip_offset + 0.5), 0.0, 4.0));
#if DEPTH16
                float z = lod == 0 ? texelFetch(depth_mips, qi, 0).r : texelFetch(depth_mips16, qi >> lod, lod - 1).r;
#else
                float z = texelFetch(depth_mips, qi >> lod, lod).r;
#endif
                if (z <= 0.0) continue;
                vec3 S = vec3((vec2(qi) + 0.5 - half_size) / focal_px * z, -z);
#else
                vec4 sp = texelFetch(g_position, qi, 0);
                if (sp.w < 0.5) continue;
                vec3 S = (view * vec4(sp.xyz, 1.0)).xyz;
                // The texel's surface point lies on the ray through the texel centre, off the slice;
                // move it along its own tangent plane onto the ray through the exact sample point q.
                vec3 n_s = mat3(view) * texelFetch(g_normal, qi, 0).xyz;
                vec3 ray = vec3((q - half_size) / focal_px, -1.0);
                float denom = dot(ray, n_s);
                if (denom < -1e-4 * length(ray)) {
                    vec3 S2 = ray * (dot(S, n_s) / denom);
                    if (abs(S2.z - S.z) < 0.05 * -S.z) S = S2;
                }
#endif
                vec3 D = S - P;
                float len = length(D);
                if (len <= 0.0) continue;
                float w = weight(length(vec3(D.xy, D.z * (1.0 + thin_occluder))));
                hc = max(hc, mix(low, dot(D, v) / len, w));
            }
            if (side == 0) hc_pos = hc; else hc_neg = hc;
        }
        float h1 = gamma + clamp(acos(clamp(hc_pos, -1.0, 1.0)) - gamma, -0.5 * PI, 0.5 * PI);
        float h0 = gamma + clamp(-acos(clamp(hc_neg, -1.0, 1.0)) - gamma, -0.5 * PI, 0.5 * PI);
        visibility += 0.25 * nlen * (arc(h0, gamma) + arc(h1, gamma));
    }
    float ao = pow(clamp(visibility / float(slices), 0.0, 1.0), final_power);
    imageStore(out_ao, p, vec4(ao));
}
