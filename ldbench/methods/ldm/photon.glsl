// Photon differentials and splats of the LDM indirect light (aalund2015 §3.4, §4.2; docs/reference/methods/ldm_indirect.md).
// Shared by photon_trace.glsl and photon_splat.glsl.
//
// A stored photon (B_PHOTONS, 64 bytes): x = the second hit x2, D_u x / D_v x = its positional
// differentials on x2's tangent plane (footprint = the ellipse inscribed in the parallelogram
// x2 +- D_u x/2 +- D_v x/2), n = the surface normal at x2 (facing the camera), flux = Phi (W, RGB).
// id = texel * N + map (mod 2^32): the primary photon's light texel and the map that traced it, for tests
// that recompute the differential from the geometry (a uint: float bits could be flushed as denormals).
#ifndef LDBENCH_PHOTON_GLSL
#define LDBENCH_PHOTON_GLSL

struct Photon {
    vec4 x_r;    // x2, flux.r
    vec4 du_g;   // D_u x2, flux.g
    vec4 dv_b;   // D_v x2, flux.b
    vec3 n;      // n2
    uint id;
};

// Igehy 1999 transfer of a ray differential (D x, D d) along direction d by t onto the plane with normal n
// (positions only; the directional differential is unchanged by a transfer).
void transfer(inout vec3 dxu, inout vec3 dxv, vec3 ddu, vec3 ddv, vec3 d, vec3 n, float t) {
    dxu += t * ddu;
    dxv += t * ddv;
    float dn = dot(d, n);
    dxu -= dot(dxu, n) / dn * d;
    dxv -= dot(dxv, n) / dn * d;
}

// The rotation quaternion alpha(a, b) taking unit vector a to unit vector b (xyz = axis * sin, w = cos
// of half the angle). For b = -a every axis perpendicular to a gives a valid half-turn: a fixed one
// (deterministic; the differential's orientation there is a convention, not physics).
vec4 quat_between(vec3 a, vec3 b) {
    float w = 1.0 + dot(a, b);
    if (w < 1e-6) {
        vec3 p = abs(a.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
        return vec4(normalize(cross(a, p)), 0.0);
    }
    return normalize(vec4(cross(a, b), w));
}

// q v q* for a unit quaternion q (Hamilton product with v as a pure quaternion).
vec3 quat_rotate(vec4 q, vec3 v) {
    return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v);
}

// Silverman's second-order kernel on the unit disc (integrates to 1).
float silverman(float l) {
    if (l >= 1.0) return 0.0;
    float s = 1.0 - l * l;
    return 3.0 / 3.14159265358979323846 * s * s;
}

// aalund2015 eq. (7): world -> filter coordinates. The parallelogram x +- du/2 +- dv/2 maps onto
// [-1, 1]^2, so the unit disc is its inscribed ellipse. Row 3 is the paper's a * n; a is given here as
// topology * sqrt(|det|) / 2, so that an offset along n of sqrt(parallelogram area) / topology reaches
// filter distance 1 (the paper's a is a length; this keeps it scale-free).
mat3 filter_matrix(vec3 du, vec3 dv, vec3 n, float topology) {
    float det = dot(du, cross(dv, n));
    float a = topology * sqrt(abs(det)) * 0.5;
    return (2.0 / det) * transpose(mat3(cross(dv, n), cross(n, du), a * n));
}

// Screen rectangle of a splat: the parallelogram's corners projected by view_proj into pixels of an
// image of `size`. False (the splat is not drawn: "clipped") when a corner lies behind the eye or the
// rectangle's diagonal exceeds max_px (the largest splat kept).
bool splat_corners(vec3 x, vec3 du, vec3 dv, mat4 view_proj, vec2 size, float max_px,
                   out vec4 c[4], out vec2 lo, out vec2 hi) {
    vec3 h = 0.5 * du, k = 0.5 * dv;
    c[0] = view_proj * vec4(x - h - k, 1.0);
    c[1] = view_proj * vec4(x + h - k, 1.0);
    c[2] = view_proj * vec4(x - h + k, 1.0);
    c[3] = view_proj * vec4(x + h + k, 1.0);
    lo = vec2(3.0e38);
    hi = vec2(-3.0e38);
    for (int i = 0; i < 4; ++i) {
        if (c[i].w <= 1e-6) return false;
        vec2 p = (c[i].xy / c[i].w * 0.5 + 0.5) * size;
        lo = min(lo, p);
        hi = max(hi, p);
    }
    return length(hi - lo) <= max_px;
}
#endif
