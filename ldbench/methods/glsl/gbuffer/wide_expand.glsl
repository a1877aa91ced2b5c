// The compute G-buffer's tile list (gbuffer/wide_list.glsl): a workgroup per listed wide triangle writes its
// tile entries (triangle, k), k = 0 .. tiles - 1, at its reserved range (grid-stride over the list).
layout(local_size_x = 256) in;
#include "gbuffer/wide_list.glsl"

void main() {
    uint n = gw_triangles;
    for (uint s = gl_WorkGroupID.x; s < n; s += gl_NumWorkGroups.x) {
        uvec4 e = gw_list[s];
        for (uint k = gl_LocalInvocationID.x; k < e.z && e.y + k < tile_capacity; k += gl_WorkGroupSize.x)
            gt_map[e.y + k] = uvec2(e.x, k);
    }
}
