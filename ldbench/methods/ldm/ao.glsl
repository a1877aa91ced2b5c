// LDM ambient occlusion / obscurance (aalund2015 §3.3, §4.1): one invocation per G-buffer pixel, a
// loop over the N maps; each map contributes the one of its two directions +-v in the hemisphere of
// the camera-facing normal. V = 1 - rho(t) (ldbench/core/effects/ao.py), weighted by cos(theta).
// estimator 0 ("ratio"):  A = sum V cos / sum cos   (exact when nothing is hit)
// estimator 1 ("paper"):  A = 2/N sum V cos          (aalund2015 eq. 2)
// Background pixels hold 1. LDM_ONE_WAY (trace.query = one_way: 2N maps along +-v_i, each answering its own
// axis): only the maps whose axis lies in the hemisphere contribute, the same N directions as two-way maps.
// LDM_PREFETCH (trace.prefetch, default 1): maps whose first list node is loaded before any is walked.
// LDM_MAP_BATCH (trace.map_batch): one dispatch walks maps [k_begin, k_end) only, so that the lists of the
// maps in flight stay in cache; the pixel's two sums carry over in ldm_ao_sums, and the sums run over k in
// the same order, so the image is the same bit for bit. The dispatch of the last batch writes the image.
// LDM_AO_GRID (trace.map_schedule = grid): all batches in one dispatch, batch = workgroup z (the slowest, so
// the batches still run one after another in cache, without a drain between them); each writes its own
// partial sums, ldm_ao_sums[batch * pixels + pixel], and LDM_AO_COMBINE (a pass over the pixels) adds them
// in batch order: the image differs from one dispatch's by float rounding only.
#include "ldm_trace.glsl"
#ifndef LDM_PREFETCH
#define LDM_PREFETCH 1
#endif
#if defined(LDM_MAP_BATCH) || defined(LDM_AO_GRID) || defined(LDM_AO_COMBINE)
layout(std430, binding = B_LDM_AO_SUMS) buffer LdmAoSums { vec2 ldm_ao_sums[]; };
#endif
#if defined(LDM_MAP_BATCH)
uniform uint k_begin;
uniform uint k_end;
#endif
#if defined(LDM_AO_GRID) || defined(LDM_AO_COMBINE)
uniform uint map_batch;   // maps per batch (workgroup z)
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform uint n_maps;
uniform float bias;        // world units
uniform float d_max;       // world units (3e38 = unbounded)
uniform int falloff;       // 0 step, 1 quadratic
uniform int estimator;     // 0 ratio, 1 paper

float rho(float t) {
    if (t >= d_max) return 0.0;
    if (falloff == 0) return 1.0;
    float q = t / d_max;
    return 1.0 - q * q;
}

// the pixel's index in the image, and the image's pixels: the sums' layout
uint ldm_pixel(ivec2 p) { return uint(p.y) * uint(imageSize(out_image).x) + uint(p.x); }
uint ldm_pixels() { return uint(imageSize(out_image).x * imageSize(out_image).y); }

float ldm_ao(float sum_vc, float sum_c) {
#if defined(LDM_ONE_WAY)
    float n_dirs = 0.5 * float(n_maps);   // 2N one-way maps answer the N directions of the hemisphere
#else
    float n_dirs = float(n_maps);
#endif
    return estimator == 0 ? (sum_c > 0.0 ? sum_vc / sum_c : 1.0) : 2.0 / n_dirs * sum_vc;
}

#if defined(LDM_AO_COMBINE)
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(out_image)))) return;
    if (texelFetch(g_position, p, 0).w < 0.5) { imageStore(out_image, p, vec4(1.0)); return; }
    uint npix = ldm_pixels(), idx = ldm_pixel(p);
    vec2 s = vec2(0.0);
    for (uint b = 0u; b * map_batch < n_maps; ++b) s += ldm_ao_sums[b * npix + idx];
    imageStore(out_image, p, vec4(ldm_ao(s.x, s.y)));
}
#else
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(out_image)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    if (pos.w < 0.5) {   // background: 1 (by the combine pass in a grid)
#if !defined(LDM_AO_GRID)
        imageStore(out_image, p, vec4(1.0));
#endif
        return;
    }
    vec3 x = pos.xyz;
    vec3 n = normalize(texelFetch(g_normal, p, 0).xyz);
    float sum_vc = 0.0, sum_c = 0.0;
    uint kb = 0u, ke = n_maps;
#if defined(LDM_AO_GRID)
    uint idx = ldm_pixel(p);
    kb = gl_WorkGroupID.z * map_batch;
    ke = min(kb + map_batch, n_maps);
#elif defined(LDM_MAP_BATCH)
    uint idx = ldm_pixel(p);
    kb = k_begin;
    ke = k_end;
    if (kb > 0u) {
        vec2 s = ldm_ao_sums[idx];
        sum_vc = s.x;
        sum_c = s.y;
    }
#endif
    // the first nodes of a batch in flight together; the sums run over k in the same order for any batch
    for (uint k0 = kb; k0 < ke; k0 += uint(LDM_PREFETCH)) {
        LdmQuery q[LDM_PREFETCH];
        uint first[LDM_PREFETCH];
        float cs[LDM_PREFETCH];   // c = n . v_k of a map that contributes, 0 for one that does not
        for (int j = 0; j < LDM_PREFETCH; ++j) {
            uint k = k0 + uint(j);
            float c = k < ke ? dot(n, ol_axes[k].v.xyz) : 0.0;
            bool skip = abs(c) < 1e-6;
#if defined(LDM_ONE_WAY)
            skip = skip || c < 0.0;  // a one-way map answers +v_k only: the maps facing away give no direction
#endif
            cs[j] = skip ? 0.0 : c;
            if (skip) continue;
            q[j] = ldm_query(k, c > 0.0 ? 1.0 : -1.0, x, n, bias);
            first[j] = ls_first(q[j].list);
        }
        for (int j = 0; j < LDM_PREFETCH; ++j) {
            if (cs[j] == 0.0) continue;
            float t = ldm_walk(q[j], cs[j] > 0.0 ? 1.0 : -1.0, first[j]);
            float ct = abs(cs[j]);
            float V = t >= 0.0 ? 1.0 - rho(t) : 1.0;
            sum_vc += V * ct;
            sum_c += ct;
        }
    }
#if defined(LDM_AO_GRID)
    ldm_ao_sums[gl_WorkGroupID.z * ldm_pixels() + idx] = vec2(sum_vc, sum_c);
#else
#if defined(LDM_MAP_BATCH)
    if (ke < n_maps) {
        ldm_ao_sums[idx] = vec2(sum_vc, sum_c);
        return;
    }
#endif
    imageStore(out_image, p, vec4(ldm_ao(sum_vc, sum_c)));
#endif
}
#endif
