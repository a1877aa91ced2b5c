// List statistics: ll_counters[LL_C_NONEMPTY] non-empty lists, [LL_C_MAXLEN] max length, [LL_C_UNSORTED]
// lists out of order, [LL_C_LINKED] nodes reached from the heads (must equal the nodes stored). Walks are
// bounded by the pool capacity (a corrupt link shows as LL_C_LINKED != stored).
#define LL_STATS 1
#include "layered/linked_list.glsl"
layout(local_size_x = 64) in;
uniform uint n_lists;
void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    uint cap = ll_capacity_bound();
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uint i = ll_head[list];
        if (i == LL_EOL) continue;
        uint len = 0u;
        bool sorted = true;
        float last = -3.402823466e38;
        while (i != LL_EOL && len <= cap) {
            LLNode nd = ll_node(i);
            if (nd.depth < last) sorted = false;
            last = nd.depth;
            ++len;
            i = nd.next;
        }
        atomicAdd(ll_counters[LL_C_NONEMPTY], 1u);
        atomicMax(ll_counters[LL_C_MAXLEN], len);
        if (!sorted) atomicAdd(ll_counters[LL_C_UNSORTED], 1u);
        atomicAdd(ll_counters[LL_C_LINKED], len);
    }
}
