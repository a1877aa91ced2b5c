// yang2010 §4.1 resolve: one full-screen pass; per pixel, walk the unsorted linked list, sort its fragments
// by the effect's order (oit_before: depth, then material id) and composite them front to back.
//
// Defines: the layered structure's (ldbench/methods/structures/: LS_LAYOUT, LS_PAYLOAD, LS_PL_MATERIAL, LL_PAGES, ...)
//   OIT_ARRAY     register array length: lists up to this long are sorted in registers
//   OIT_FIRST_N   composite only the n nearest fragments (yang2010's first n layers)
// A list of L <= OIT_ARRAY fragments is gathered into the array and sorted: all of it by insertion sort
// (~L^2/4 steps), or with OIT_FIRST_N = n and 4n < L only its first n places by selection (~nL steps: the
// cheap extraction of the n closest layers that makes the layer cap pay). A longer list is composited
// exactly by repeated minimum search over the list itself (O(nL); counted in oit_counters[0]).
#include "layered/layered.glsl"
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
void main() { gl_Position = oit_fullscreen(gl_VertexID); }

#elif defined(FRAGMENT_SHADER)
#ifndef OIT_ARRAY
#define OIT_ARRAY 64
#endif
const uint K = uint(OIT_ARRAY);
uniform ivec2 size;
uniform vec3 background;
layout(std430, binding = B_OIT_COUNTERS) buffer OITCounters { uint oit_counters[]; };
layout(location = 0) out vec4 out_color;

void blend(inout vec3 C, inout float T, uint m) {
    vec4 a = oit_material[m];
    C += T * a.a * a.rgb;
    T *= 1.0 - a.a;
}

void main() {
    uint list = ls_list(0u, ivec2(gl_FragCoord.xy), size);
    uint bound = ls_bound();
    float z[OIT_ARRAY];
    uint m[OIT_ARRAY];
    uint n = 0u;
    for (uint i = ls_first(list), s = 0u; i != LS_END && s < bound; i = ls_next(list, i), ++s) {
        if (n < K) { z[n] = ls_depth(i); m[n] = ls_payload(i, uint(LS_PL_MATERIAL)); }
        ++n;
    }
#if defined(OIT_FIRST_N)
    uint layers = min(n, uint(OIT_FIRST_N));
#else
    uint layers = n;
#endif
    vec3 C = vec3(0.0);
    float T = 1.0;
    if (n <= K) {
        if (4u * layers < n) {
            for (uint a = 0u; a < layers; ++a) {          // selection of the first `layers` places
                uint s = a;
                for (uint b = a + 1u; b < n; ++b) if (oit_before(z[b], m[b], z[s], m[s])) s = b;
                float zs = z[s]; uint ms = m[s];
                z[s] = z[a]; m[s] = m[a];
                z[a] = zs; m[a] = ms;
            }
        } else {
            for (uint a = 1u; a < n; ++a) {               // insertion sort (yang2010 §4.1.1)
                float za = z[a];
                uint ma = m[a];
                uint b = a;
                while (b > 0u && oit_before(za, ma, z[b - 1u], m[b - 1u])) { z[b] = z[b - 1u]; m[b] = m[b - 1u]; --b; }
                z[b] = za;
                m[b] = ma;
            }
        }
        for (uint k = 0u; k < layers; ++k) blend(C, T, m[k]);
    } else {
        atomicAdd(oit_counters[0], 1u);
        // the next fragment is the least (depth, material, node) strictly after the last one composited
        float lz = 0.0;
        uint lm = 0u, li = 0u;
        bool first = true;
        for (uint k = 0u; k < layers; ++k) {
            float bz = 0.0;
            uint bm = 0u, bi = LS_END;
            for (uint i = ls_first(list), s = 0u; i != LS_END && s < bound; i = ls_next(list, i), ++s) {
                float zi = ls_depth(i);
                uint mi = ls_payload(i, uint(LS_PL_MATERIAL));
                bool after = first || oit_before(lz, lm, zi, mi) || (zi == lz && mi == lm && i > li);
                bool better = bi == LS_END || oit_before(zi, mi, bz, bm) || (zi == bz && mi == bm && i < bi);
                if (after && better) { bz = zi; bm = mi; bi = i; }
            }
            if (bi == LS_END) break;
            blend(C, T, bm);
            lz = bz; lm = bm; li = bi;
            first = false;
        }
    }
    out_color = vec4(C + T * background, n > 0u ? 1.0 : 0.0);
}
#endif
