// Sort every list in place by ascending depth (the sort step of the unsorted yang2010 variant).
// Lists of up to LL_MAX_LIST nodes: gathered into a local array, insertion sort, depths written back
// along the same chain. Longer lists: counted in ll_counters[1] and sorted in place in global memory
// (selection sort over the chain: O(L^2) but exact), so nothing is truncated.
#define LL_WRITABLE 1
#include "linked_list.glsl"
#ifndef LL_MAX_LIST
#define LL_MAX_LIST 64
#endif
layout(local_size_x = 64) in;
uniform uint n_lists;
uniform uint ll_capacity;

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        float d[LL_MAX_LIST];
        uint count = 0u;
        uint i = ll_head[list];
        while (i != LL_EOL && count < uint(LL_MAX_LIST)) {
            LLNode nd = ll_node(i);
            d[count++] = nd.depth;
            i = nd.next;
        }
        if (i == LL_EOL) {
            for (uint a = 1u; a < count; ++a) {     // insertion sort
                float z = d[a];
                uint b = a;
                while (b > 0u && d[b - 1u] > z) { d[b] = d[b - 1u]; --b; }
                d[b] = z;
            }
            i = ll_head[list];
            for (uint a = 0u; a < count; ++a) { ll_set_depth(i, d[a]); i = ll_next(i); }
        } else {
            atomicAdd(ll_counters[1], 1u);
            uint guard = 0u;
            for (uint a = ll_head[list]; a != LL_EOL && guard < ll_capacity; a = ll_next(a), ++guard) {
                uint m = a;
                float zm = ll_depth(a);
                for (uint b = ll_next(a); b != LL_EOL; b = ll_next(b)) {
                    float zb = ll_depth(b);
                    if (zb < zm) { m = b; zm = zb; }
                }
                if (m != a) { ll_set_depth(m, ll_depth(a)); ll_set_depth(a, zm); }
            }
        }
    }
}
