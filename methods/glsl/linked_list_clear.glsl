// Fill ll_head[0 .. n) with LL_EOL (grid-stride loop: any n with a bounded dispatch).
#define LL_WRITABLE 1
#include "linked_list.glsl"
layout(local_size_x = 256) in;
uniform uint n;
void main() {
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += stride) ll_head[i] = LL_EOL;
}
