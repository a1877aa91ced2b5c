// Stress test of the lock-free sorted insert (tests/test_layered.py): n_inserts invocations insert
// pseudo-random depths into n_lists lists at once, from many workgroups (on llvmpipe: several CPU
// threads), so inserts into one list race on the same predecessors.
#define LL_WRITABLE 1
#include "layered/linked_list.glsl"
layout(local_size_x = 64) in;
uniform uint n_inserts;
uniform uint n_lists;
uniform uint capacity;
uint hash(uint x) {  // lowbias32
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= n_inserts) return;
    float z = float(hash(i) & 0xFFFFFu) / 1048576.0;
    ll_insert_sorted(i % n_lists, z, capacity);
}
