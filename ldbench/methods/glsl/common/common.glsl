// Shared definitions: the spot light of docs/design.md (Mitsuba 3 `spot`), G-buffer bindings.
#ifndef LDBENCH_COMMON_GLSL
#define LDBENCH_COMMON_GLSL

const float PI = 3.14159265358979323846;

struct SpotLight {
    vec3 position; float cos_cutoff;
    vec3 axis;     float cutoff;       // radians
    vec3 intensity; float beam;        // radians
};

// Mitsuba 3 spot fall-off: 1 inside the beam width, linear in angle down to 0 at the cutoff angle.
float spot_falloff(SpotLight L, vec3 dir_from_light) {
    float c = dot(normalize(dir_from_light), L.axis);
    if (L.cutoff >= PI - 1e-6) return 1.0;          // point light
    if (c <= L.cos_cutoff) return 0.0;
    float theta = acos(clamp(c, -1.0, 1.0));
    if (theta <= L.beam) return 1.0;
    return (L.cutoff - theta) / max(L.cutoff - L.beam, 1e-6);
}

// Irradiance-like factor of a delta spot light at x with normal n (n faces the viewer):
// I * falloff * max(0, cos) / d^2, without visibility.
vec3 spot_irradiance(SpotLight L, vec3 x, vec3 n) {
    vec3 d = x - L.position;
    float d2 = dot(d, d);
    float cos_s = dot(n, -d) * inversesqrt(d2);
    if (cos_s <= 0.0) return vec3(0.0);
    return L.intensity * spot_falloff(L, d) * cos_s / d2;
}

#endif
