// Sort assembly of the linearised arrays (ldbench/methods/structures/linear.py, assembly = "sort"), the scatter:
// the emit pass appended every fragment as a pair (list, depth bits, payload words...) to ls_pairs and
// counted it in la_off[list]; after the exclusive scan each pair takes slot = atomicAdd(la_off[list], 1)
// (a counting sort by list id; afterwards la_off[i] = end of list i, the layout's convention) and is
// copied there. The per-list depth sort (layered/linear_sort.glsl) follows.
#define LA_WRITABLE 1
#include "layered/linear_arrays.glsl"
#define LS_PAIR_WORDS (2 + LS_PAYLOAD)
layout(local_size_x = 256) in;
layout(std430, binding = B_PAIRS) readonly buffer LSPairs { uint ls_pairs[]; };
void main() {
    uint cap = la_counters[LA_C_CAPACITY];
    uint n = min(la_counters[LA_C_EMITTED], cap);
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += stride) {
        uint s = i * uint(LS_PAIR_WORDS);
        uint slot = atomicAdd(la_off[ls_pairs[s]], 1u);
        if (slot >= cap) continue;   // never: the counts are those of the stored pairs
        la_depth[slot] = uintBitsToFloat(ls_pairs[s + 1u]);
#if LS_PAYLOAD > 0
        for (uint k = 0u; k < uint(LS_PAYLOAD); ++k)
            la_payload[slot * uint(LS_PAYLOAD) + k] = ls_pairs[s + 2u + k];
#endif
    }
}
