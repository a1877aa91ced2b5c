// Sort every list in place by ascending depth (the sort step of the unsorted yang2010 variant), or with
// LL_SORT_LISTED only the lists the build left unsorted.
// Lists of up to LL_MAX_LIST nodes: their depths insertion-sorted into a local array as the walk reads them, the depths
// that changed written back along a second walk of the same chain (no array of node indices: the smaller local array is
// faster, docs/reference/methods/fast_builds.md); with a payload the node indices are kept too and node contents swapped by a selection
// sort. Longer lists: counted in ll_counters[LL_C_SORT_LONG] and sorted in place in global memory (selection sort
// over the chain: O(L^2) but exact), so nothing is truncated. Every walk is bounded by the pool capacity.
#define LL_WRITABLE 1
#include "layered/linked_list.glsl"
#ifndef LL_MAX_LIST
#define LL_MAX_LIST 64
#endif
layout(local_size_x = 64) in;
uniform uint n_lists;

void ll_swap_nodes(uint a, uint b) {  // exchange the contents (depth and payload) of nodes a and b
    float z = ll_depth(a);
    ll_set_depth(a, ll_depth(b));
    ll_set_depth(b, z);
#if LS_PAYLOAD > 0
    for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) {
        uint w = ll_payload[a * uint(LS_PAYLOAD) + k];
        ll_payload[a * uint(LS_PAYLOAD) + k] = ll_payload[b * uint(LS_PAYLOAD) + k];
        ll_payload[b * uint(LS_PAYLOAD) + k] = w;
    }
#endif
}

void ll_sort_list(uint list, uint cap) {
    float d[LL_MAX_LIST];
#if LS_PAYLOAD > 0
    uint idx[LL_MAX_LIST];
#endif
    uint count = 0u;
    uint i = ll_head[list];
    while (i != LL_EOL && count < uint(LL_MAX_LIST)) {
        LLNode nd = ll_node(i);
#if LS_PAYLOAD == 0
        uint b = count;                          // inserted as read: one loop over the list, not a gather and a sort
        while (b > 0u && d[b - 1u] > nd.depth) { d[b] = d[b - 1u]; --b; }
        d[b] = nd.depth;
#else
        d[count] = nd.depth;
        idx[count] = i;
#endif
        i = nd.next;
        ++count;
    }
    if (i == LL_EOL) {
#if LS_PAYLOAD == 0
        uint j = ll_head[list];                  // the chain again: its a-th node takes the a-th depth
        for (uint a = 0u; a < count; ++a) {
            LLNode nd = ll_node(j);
            if (nd.depth != d[a]) ll_set_depth(j, d[a]);
            j = nd.next;
        }
#else
        for (uint a = 0u; a + 1u < count; ++a) { // selection sort of the node contents (payload moves too)
            uint m = a;
            for (uint b = a + 1u; b < count; ++b) if (d[b] < d[m]) m = b;
            if (m != a) { ll_swap_nodes(idx[a], idx[m]); float z = d[a]; d[a] = d[m]; d[m] = z; }
        }
#endif
    } else {
        atomicAdd(ll_counters[LL_C_SORT_LONG], 1u);
        uint guard = 0u;
        for (uint a = ll_head[list]; a != LL_EOL && guard < cap; a = ll_next(a), ++guard) {
            uint m = a;
            float zm = ll_depth(a);
            uint inner = guard;
            for (uint b = ll_next(a); b != LL_EOL && inner < cap; b = ll_next(b), ++inner) {
                float zb = ll_depth(b);
                if (zb < zm) { m = b; zm = zb; }
            }
            if (m != a) ll_swap_nodes(a, m);
        }
    }
}

#if defined(LL_SORT_LISTED)
// only the lists a pass left unsorted (layered/splat_tiles.glsl, SP_TILE_SORT); every list when they were more than
// the buffer holds
layout(std430, binding = B_SPLAT_SORT) readonly buffer SplatSortLists { uint sp_sort_n; uint sp_sort_list[]; };
uniform uint sp_sort_cap;
#endif

void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    uint cap = ll_capacity_bound();
#if defined(LL_SORT_LISTED)
    uint listed = sp_sort_n;
    if (listed <= sp_sort_cap) {
        for (uint e = gl_GlobalInvocationID.x; e < listed; e += stride) ll_sort_list(sp_sort_list[e], cap);
        return;
    }
#endif
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) ll_sort_list(list, cap);
}
