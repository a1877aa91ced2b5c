// Sort every list in place by ascending depth (the sort step of the unsorted yang2010 variant): one
// invocation per list (linked_list_sort_list.glsl).
#define LL_WRITABLE 1
#include "linked_list.glsl"
#include "linked_list_sort_list.glsl"
layout(local_size_x = 64) in;
uniform uint n_lists;

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    uint cap = ll_capacity_bound();
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) ll_sort_list(list, cap);
}
