// The six rays of a VPL, the GLSL twin of ldbench/core/effects/vpl_range.py vpl_directions (the hash and the frame
// are those of common/conventions.glsl):
// ray 0 along the primary direction p, rays 1..5 at cone_angle from p, azimuths phi0 + 2 pi k / 5 in the
// Duff et al. (2017) frame of p, phi0 = 2 pi hash01(texel, seed).
#ifndef LDBENCH_VPL_GLSL
#define LDBENCH_VPL_GLSL
#include "common/conventions.glsl"
#define VPL_TWO_PI 6.28318530717958648

// Direction of ray k (0..5) of a VPL with primary direction p.
vec3 vpl_ray_dir(uint k, vec3 p, vec3 t, vec3 b, float phi0, float cos_a, float sin_a) {
    if (k == 0u) return p;
    float phi = phi0 + float(k - 1u) * (VPL_TWO_PI / 5.0);
    return normalize(p * cos_a + t * (sin_a * cos(phi)) + b * (sin_a * sin(phi)));
}
#endif
