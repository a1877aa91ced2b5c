// fill_data[0 .. n) = value (grid-stride loop: any n with a bounded dispatch). Clears list heads and
// per-list counters.
layout(local_size_x = 256) in;
layout(std430, binding = B_FILL) writeonly buffer FillData { uint fill_data[]; };
uniform uint n;
uniform uint value;
void main() {
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += stride) fill_data[i] = value;
}
