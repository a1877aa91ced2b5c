// Exclusive prefix sum of a uint array in place (ldbench/methods/scan.py), 1024 elements per workgroup of 256
// invocations: each invocation sums 4 consecutive elements, the workgroup scans the 256 partial sums in
// shared memory (Hillis-Steele, 8 steps), and writes the block back.
//   SCAN_BLOCKS: scan every block of scan_data[0 .. n) in place; block b's total goes to scan_sums[b].
//   SCAN_ADD:    scan_data[i] += scan_sums[i / 1024] (the scanned block totals).
// Workgroups are numbered over a 2D dispatch (x < 65535), so n is only bounded by the buffer.
layout(local_size_x = 256) in;
layout(std430, binding = B_SCAN_DATA) buffer ScanData { uint scan_data[]; };
layout(std430, binding = B_SCAN_SUMS) buffer ScanSums { uint scan_sums[]; };
uniform uint n;
shared uint partial[256];

void main() {
    uint block = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint base = block * 1024u + gl_LocalInvocationID.x * 4u;
#if defined(SCAN_BLOCKS)
    uint v[4];
    uint s = 0u;
    for (uint k = 0u; k < 4u; ++k) {
        v[k] = base + k < n ? scan_data[base + k] : 0u;
        s += v[k];
    }
    uint t = gl_LocalInvocationID.x;
    partial[t] = s;
    barrier();
    for (uint off = 1u; off < 256u; off <<= 1u) {
        uint add = t >= off ? partial[t - off] : 0u;
        barrier();
        partial[t] += add;
        barrier();
    }
    uint run = partial[t] - s;          // exclusive prefix of this invocation's 4 elements
    for (uint k = 0u; k < 4u; ++k) {
        if (base + k < n) scan_data[base + k] = run;
        run += v[k];
    }
    if (t == 255u) scan_sums[block] = partial[255];
#elif defined(SCAN_ADD)
    uint add = scan_sums[block];
    for (uint k = 0u; k < 4u; ++k)
        if (base + k < n) scan_data[base + k] += add;
#endif
}
