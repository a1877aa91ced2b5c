// Canonical order of every list: ascending (depth bits, payload word 0, word 1, ...). Lists arrive sorted
// by depth (both builds), so this insertion sort only reorders fragments at exactly equal depth, whose
// order the one-pass build leaves to its atomics and the peel to triangle ids. After it, both builds are
// bit-identical (tests/test_ldi.py).
#define LA_WRITABLE 1
#include "layered/layered.glsl"
#include "layered/ldi_common.glsl"
layout(local_size_x = 64) in;
uniform uint n_lists;

bool key_less(uint a, uint b) {   // fragment a sorts before fragment b
    uint oa = ldi_order(la_depth[a]), ob = ldi_order(la_depth[b]);
    if (oa != ob) return oa < ob;
#if LS_PAYLOAD > 0
    for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) {
        uint wa = la_payload[a * uint(LS_PAYLOAD) + k], wb = la_payload[b * uint(LS_PAYLOAD) + k];
        if (wa != wb) return wa < wb;
    }
#endif
    return false;
}

void swap_nodes(uint a, uint b) {
    float t = la_depth[a]; la_depth[a] = la_depth[b]; la_depth[b] = t;
#if LS_PAYLOAD > 0
    for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) {
        uint w = la_payload[a * uint(LS_PAYLOAD) + k];
        la_payload[a * uint(LS_PAYLOAD) + k] = la_payload[b * uint(LS_PAYLOAD) + k];
        la_payload[b * uint(LS_PAYLOAD) + k] = w;
    }
#endif
}

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uint b = la_begin(list), e = la_end(list);
        for (uint i = b + 1u; i < e; ++i)
            for (uint j = i; j > b && key_less(j, j - 1u); --j) swap_nodes(j, j - 1u);
    }
}
