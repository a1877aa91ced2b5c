// Sort every linearised list in place by ascending depth (archer2019's per-pixel sort), payload words with
// it. Lists of up to LA_MAX_LIST fragments: gathered into registers, insertion sort, written back. Longer
// lists: counted in la_counters[LA_C_SORT_LONG] and insertion-sorted in global memory (exact, O(L^2)).
#define LA_WRITABLE 1
#include "layered/linear_arrays.glsl"
#ifndef LA_MAX_LIST
#define LA_MAX_LIST 32
#endif
layout(local_size_x = 64) in;
uniform uint n_lists;

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uint b = la_begin(list), e = la_end(list), len = e - b;
        if (len < 2u) continue;
        if (len <= uint(LA_MAX_LIST)) {
            float d[LA_MAX_LIST];
#if LS_PAYLOAD > 0
            uint perm[LA_MAX_LIST];
#endif
            for (uint a = 0u; a < len; ++a) {
                float z = la_depth[b + a];
                uint c = a;
                while (c > 0u && d[c - 1u] > z) {
                    d[c] = d[c - 1u];
#if LS_PAYLOAD > 0
                    perm[c] = perm[c - 1u];
#endif
                    --c;
                }
                d[c] = z;
#if LS_PAYLOAD > 0
                perm[c] = a;
#endif
            }
            for (uint a = 0u; a < len; ++a) la_depth[b + a] = d[a];
#if LS_PAYLOAD > 0
            for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) {      // permute each payload word in registers
                uint w[LA_MAX_LIST];
                for (uint a = 0u; a < len; ++a) w[a] = la_payload[(b + a) * uint(LS_PAYLOAD) + k];
                for (uint a = 0u; a < len; ++a) la_payload[(b + a) * uint(LS_PAYLOAD) + k] = w[perm[a]];
            }
#endif
        } else {
            atomicAdd(la_counters[LA_C_SORT_LONG], 1u);
            for (uint a = b + 1u; a < e; ++a) {
                float z = la_depth[a];
#if LS_PAYLOAD > 0
                uint w[LS_PAYLOAD];
                for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) w[k] = la_payload[a * uint(LS_PAYLOAD) + k];
#endif
                uint c = a;
                while (c > b && la_depth[c - 1u] > z) {
                    la_depth[c] = la_depth[c - 1u];
#if LS_PAYLOAD > 0
                    for (uint k = 0u; k < uint(LS_PAYLOAD); ++k)
                        la_payload[c * uint(LS_PAYLOAD) + k] = la_payload[(c - 1u) * uint(LS_PAYLOAD) + k];
#endif
                    --c;
                }
                la_depth[c] = z;
#if LS_PAYLOAD > 0
                for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) la_payload[c * uint(LS_PAYLOAD) + k] = w[k];
#endif
            }
        }
    }
}
