// List statistics: ll_counters[2] non-empty lists, [3] max length, [4] lists out of order,
// [5] nodes reached from the heads (must equal the nodes stored). Lists are walked at most
// ll_capacity steps (a guard against corrupt links, which would show as [5] != stored).
#include "linked_list.glsl"
layout(local_size_x = 64) in;
uniform uint n_lists;
uniform uint ll_capacity;
void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uint i = ll_head[list];
        if (i == LL_EOL) continue;
        uint len = 0u;
        bool sorted = true;
        float last = -3.402823466e38;
        while (i != LL_EOL && len <= ll_capacity) {
            LLNode nd = ll_node(i);
            if (nd.depth < last) sorted = false;
            last = nd.depth;
            ++len;
            i = nd.next;
        }
        atomicAdd(ll_counters[2], 1u);
        atomicMax(ll_counters[3], len);
        if (!sorted) atomicAdd(ll_counters[4], 1u);
        atomicAdd(ll_counters[5], len);
    }
}
