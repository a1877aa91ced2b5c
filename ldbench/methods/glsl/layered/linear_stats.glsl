// Linearised-array statistics: la_counters[LA_C_NONEMPTY] non-empty lists, [LA_C_MAXLEN] longest list,
// [LA_C_UNSORTED] lists out of depth order.
#define LA_STATS 1
#include "layered/linear_arrays.glsl"
layout(local_size_x = 64) in;
uniform uint n_lists;
void main() {
    uint stride = gl_NumWorkGroups.x * 64u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uint b = la_begin(list), e = la_end(list);
        if (e <= b) continue;
        bool sorted = true;
        for (uint i = b + 1u; i < e; ++i) if (la_depth[i] < la_depth[i - 1u]) sorted = false;
        atomicAdd(la_counters[LA_C_NONEMPTY], 1u);
        atomicMax(la_counters[LA_C_MAXLEN], e - b);
        if (!sorted) atomicAdd(la_counters[LA_C_UNSORTED], 1u);
    }
}
