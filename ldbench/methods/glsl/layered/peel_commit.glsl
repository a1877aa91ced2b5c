// After the two raster passes of one peel (layered/peel.glsl): every texel with a candidate makes it its layer m
// (pl_prev), counts it (pl_count = layers so far) and appends (texel, m, depth bits, triangle) to the
// scratch list; pl_counters[0] = fragments of this layer (0: peeling is complete), [1] = all so far.
#include "layered/ldi_common.glsl"
layout(local_size_x = 256) in;
uniform uint n_lists;
uniform uint capacity;   // scratch entries
layout(std430, binding = B_PEEL_PREV) buffer PeelPrev { uvec2 pl_prev[]; };
layout(std430, binding = B_PEEL_CAND) buffer PeelCand { uvec2 pl_cand[]; };
layout(std430, binding = B_PEEL_COUNT) buffer PeelCount { uint pl_count[]; };
layout(std430, binding = B_PEEL_LOC) writeonly buffer PeelLoc { uvec2 pl_loc[]; };
layout(std430, binding = B_PEEL_FRAG) writeonly buffer PeelFrag { uvec2 pl_frag[]; };
layout(std430, binding = B_PEEL_COUNTERS) buffer PeelCounters { uint pl_counters[4]; };

void main() {
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint list = gl_GlobalInvocationID.x; list < n_lists; list += stride) {
        uvec2 c = pl_cand[list];
        if (c.x == LDI_NONE) continue;
        pl_cand[list] = uvec2(LDI_NONE);
        pl_prev[list] = c;
        uint m = pl_count[list];
        pl_count[list] = m + 1u;
        atomicAdd(pl_counters[0], 1u);
        uint slot = atomicAdd(pl_counters[1], 1u);
        if (slot < capacity) {
            pl_loc[slot] = uvec2(list, m);
            pl_frag[slot] = c;
        } else {
            atomicAdd(pl_counters[2], 1u);   // never: the host grows the scratch list before each pass
        }
    }
}
