// Ray conventions, the GLSL twin of ldbench/core/conventions.py (which documents them; tests/test_conventions.py
// checks that both agree): the secondary-ray origin, the Duff et al. (2017) tangent frame, the sampling
// warps, the integer hashes behind the random numbers, and the clamp and reduction of a VPL's six distances.
#ifndef LDBENCH_CONVENTIONS_GLSL
#define LDBENCH_CONVENTIONS_GLSL
#define CONV_TWO_PI 6.28318530717958648
const float CONV_RAY_EPSILON = 8.940697e-05;     // Mitsuba 3's float32 math.RayEpsilon
const float CONV_SHADOW_EPSILON = 8.940697e-04;  // Mitsuba 3's float32 math.ShadowEpsilon

// eps(x) = (1 + max|x|) * ray_eps
float ray_offset_scale(vec3 x, float ray_eps) { return (1.0 + max(max(abs(x.x), abs(x.y)), abs(x.z))) * ray_eps; }

// o = x + eps n, n the unit normal of the side the ray leaves from (Mitsuba's spawn_ray offset)
vec3 spawn_origin(vec3 x, vec3 n, float ray_eps) { return x + n * ray_offset_scale(x, ray_eps); }

// x = p0 + uv.x e1 + uv.y e2 moved towards its triangle's centroid until CONV_CREASE eps(x) from every edge
// (unchanged when it already is, or when the triangle is degenerate)
#define CONV_CREASE 4.0
vec3 crease_point(vec3 x, vec3 e1, vec3 e2, vec2 uv, float ray_eps) {
    float area2 = length(cross(e1, e2));
    if (!(area2 > 0.0)) return x;
    vec3 b = vec3(1.0 - uv.x - uv.y, uv.x, uv.y);
    vec3 h = area2 / vec3(length(e2 - e1), length(e2), length(e1));
    float delta = CONV_CREASE * ray_offset_scale(x, ray_eps);
    float lam = 0.0;
    for (int i = 0; i < 3; ++i) {
        float dist = b[i] * h[i];
        if (dist < delta) lam = max(lam, b[i] < 1.0 / 3.0 ? (delta - dist) / ((1.0 / 3.0 - b[i]) * h[i]) : 1.0);
    }
    lam = clamp(lam, 0.0, 1.0);
    return lam > 0.0 ? x + lam * ((1.0 / 3.0 - uv.x) * e1 + (1.0 / 3.0 - uv.y) * e2) : x;
}

// (t, b) completing the unit vector n to an orthonormal basis (Duff et al. 2017)
void tangent_frame(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// the unit direction at polar cosine cos_t and azimuth phi about axis, in its tangent frame
vec3 around(vec3 axis, float cos_t, float phi) {
    vec3 t, b;
    tangent_frame(axis, t, b);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    return normalize(t * (sin_t * cos(phi)) + b * (sin_t * sin(phi)) + axis * cos_t);
}
vec3 cosine_direction(vec3 n, float u0, float u1) { return around(n, sqrt(1.0 - u0), CONV_TWO_PI * u1); }
vec3 phong_direction(vec3 axis, float exponent, float u0, float u1) {
    return around(axis, pow(u0, 1.0 / (exponent + 1.0)), CONV_TWO_PI * u1);
}
vec3 sphere_point(vec3 c, float r, float u0, float u1) {
    float z = 1.0 - 2.0 * u0;
    float rr = sqrt(max(0.0, 1.0 - z * z));
    float phi = CONV_TWO_PI * u1;
    return c + r * vec3(rr * cos(phi), rr * sin(phi), z);
}

// Chris Wellons' lowbias32; hash01 = top 24 bits of lowbias32(texel + lowbias32(seed)) / 2^24
uint lowbias32(uint x) {
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}
float hash01(uint texel, uint seed) { return float(lowbias32(texel + lowbias32(seed)) >> 8) * (1.0 / 16777216.0); }

// PCG-RXS-M-XS hash; a sample's stream pcg(pixel ^ pcg(seed ^ pcg(sample))), uniforms (pcg(state) >> 8) / 2^24
uint pcg_hash(uint v) {
    uint s = v * 747796405u + 2891336453u;
    uint word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (word >> 22u) ^ word;
}
uint sample_stream(uint pixel, uint seed, uint sample_index) {
    return pcg_hash(pixel ^ pcg_hash(seed ^ pcg_hash(sample_index)));
}
float pcg_uniform(inout uint state) { state = pcg_hash(state); return float(state >> 8) * (1.0 / 16777216.0); }

// a VPL ray's distance clamped to the miss range (a miss, NaN or negative "no hit" counts cap) and the
// reduction of six of them: range_max != 0: max, else mean (accumulate with range_accumulate from 0)
float range_clamp(float t, float cap) { return (t >= 0.0 && t < cap) ? t : cap; }
float range_accumulate(float acc, float t, float cap, int range_max) {
    float c = range_clamp(t, cap);
    return range_max != 0 ? max(acc, c) : acc + c;
}
float range_finish(float acc, int range_max) { return range_max != 0 ? acc : acc / 6.0; }
#endif
