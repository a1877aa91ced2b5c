// Light-grid buffers and cell addressing (grid.glsl, shade.glsl).
#ifndef LDBENCH_CDI_GRID_GLSL
#define LDBENCH_CDI_GRID_GLSL
uniform vec3 grid_lo;
uniform float grid_cell;
uniform ivec3 grid_dims;
uniform uint grid_capacity;
layout(std430, binding = B_GRID_OFF) coherent buffer GridOff { uint grid_off[]; };
layout(std430, binding = B_GRID_IDX) buffer GridIdx { uint grid_idx[]; };
layout(std430, binding = B_GRID_MASK) buffer GridMask { uint grid_mask[]; };
layout(std430, binding = B_GRID_OVERFLOW) buffer GridOverflow { uint grid_overflow[]; };
ivec3 grid_cell_of(vec3 p) { return clamp(ivec3(floor((p - grid_lo) / grid_cell)), ivec3(0), grid_dims - 1); }
uint grid_cell_index(ivec3 c) { return uint((c.z * grid_dims.y + c.y) * grid_dims.x + c.x); }
uint grid_begin(uint c) { return c == 0u ? 0u : min(grid_off[c - 1u], grid_capacity); }
uint grid_end(uint c) { return min(grid_off[c], grid_capacity); }
#endif
