// The six rays of a VPL, the GLSL twin of harness/effects/vpl_range.py (vpl_directions, hash01, frame):
// ray 0 along the primary direction p, rays 1..5 at cone_angle from p, azimuths phi0 + 2 pi k / 5 in the
// Duff et al. (2017) frame of p, phi0 = 2 pi hash01(texel, seed).
#ifndef LDBENCH_VPL_GLSL
#define LDBENCH_VPL_GLSL
#define VPL_TWO_PI 6.28318530717958648

uint vpl_hash32(uint x) {              // Chris Wellons' lowbias32
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}
float vpl_hash01(uint texel, uint seed) { return float(vpl_hash32(texel + vpl_hash32(seed)) >> 8) * (1.0 / 16777216.0); }

void vpl_frame(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * bb, -s * n.x);
    b = vec3(bb, s + n.y * n.y * a, -n.y);
}

// Direction of ray k (0..5) of a VPL with primary direction p.
vec3 vpl_ray_dir(uint k, vec3 p, vec3 t, vec3 b, float phi0, float cos_a, float sin_a) {
    if (k == 0u) return p;
    float phi = phi0 + float(k - 1u) * (VPL_TWO_PI / 5.0);
    return normalize(p * cos_a + t * (sin_a * cos(phi)) + b * (sin_a * sin(phi)));
}
#endif
