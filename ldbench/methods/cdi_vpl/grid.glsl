// The 3D light grid (archer2019 §3.2, "hybrid lighting"): cells of grid_cell metres over the scene bounds,
// each holding the indices of the VPLs whose sphere (position, range) overlaps it, as linearised arrays
// (count -> ldbench/methods/scan.py prefix sum -> fill, the layout of ldbench/methods/glsl/layered/linear_arrays.glsl: after the fill
// grid_off[c] is the end of cell c's list and the beginning of c + 1's).
//   GRID_MASK   one invocation per G-buffer pixel: grid_mask[cell of its surface] = 1 (the depth mask: no
//               VPL goes into a cell no visible surface lies in; depth_mask = False: the host sets all 1)
//   GRID_COUNT  one invocation per VPL: atomicAdd(grid_off[c], 1) for every masked cell its sphere overlaps
//   GRID_FILL   the same cells: slot = atomicAdd(grid_off[c], 1), grid_idx[slot] = VPL
#include "grid_common.glsl"
#if defined(GRID_MASK)
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D g_position;
void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(g_position, 0);
    if (px.x >= size.x || px.y >= size.y) return;
    vec4 p = texelFetch(g_position, px, 0);
    if (p.w < 0.5) return;
    grid_mask[grid_cell_index(grid_cell_of(p.xyz))] = 1u;
}
#else
struct Vpl { vec4 pos_range; vec4 normal_area; vec4 flux; };
layout(std430, binding = B_VPLS) readonly buffer Vpls { Vpl vpls[]; };
layout(local_size_x = 64) in;
uniform uint n_vpls;
void main() {
  for (uint j = gl_GlobalInvocationID.x; j < n_vpls; j += gl_NumWorkGroups.x * 64u) {  // grid-stride
    vec4 pr = vpls[j].pos_range;
    float r = pr.w;
    if (!(r > 0.0)) continue;
    ivec3 lo = grid_cell_of(pr.xyz - r), hi = grid_cell_of(pr.xyz + r);
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                vec3 bmin = grid_lo + grid_cell * vec3(x, y, z);
                vec3 e = max(max(bmin - pr.xyz, pr.xyz - (bmin + grid_cell)), 0.0);
                if (dot(e, e) > r * r) continue;
                uint c = grid_cell_index(ivec3(x, y, z));
                if (grid_mask[c] == 0u) continue;
#if defined(GRID_COUNT)
                atomicAdd(grid_off[c], 1u);
#else
                uint slot = atomicAdd(grid_off[c], 1u);
                if (slot < grid_capacity) grid_idx[slot] = j;
                else atomicAdd(grid_overflow[0], 1u);
#endif
            }
  }
}
#endif
