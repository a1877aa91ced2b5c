// example-ao: normal-oriented hemisphere SSAO on ldbench's shared G-buffer (see example_ao/__init__.py).
#include "common/common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D g_position;   // world position, w = 1 where the pixel's view ray hits
uniform sampler2D g_normal;     // world-space geometric normal, turned to face the camera
uniform mat4 view_proj;         // world -> clip, the G-buffer's own
uniform vec3 eye;
uniform int samples;
uniform float radius;           // world units
uniform float d_max;
uniform int quadratic;
uniform uint seed;

uint hash(uint x) {             // a 32-bit integer hash (lowbias32)
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}
float u01(uint x) { return float(hash(x) >> 8) * (1.0 / 16777216.0); }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);   // texel (x, y): y = 0 is the bottom row
    if (pos.w < 0.5) { imageStore(out_ao, p, vec4(1.0)); return; }
    vec3 P = pos.xyz;
    vec3 n = normalize(texelFetch(g_normal, p, 0).xyz);
    vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
    vec3 b = cross(n, t);
    uint key = hash(uint(p.x) * 73856093u ^ uint(p.y) * 19349663u ^ seed * 83492791u);
    float rot = 6.2831853 * u01(key);
    float dP = distance(eye, P);
    float occ = 0.0;
    for (int i = 0; i < samples; ++i) {
        float z = (float(i) + 0.5) / float(samples);          // cosine-weighted: sin^2(theta) uniform
        float s = sqrt(z), c = sqrt(1.0 - z);
        float phi = float(i) * 2.39996323 + rot;               // golden-angle spiral
        vec3 d = t * (s * cos(phi)) + b * (s * sin(phi)) + n * c;
        vec3 S = P + n * (1e-4 * dP) + d * (radius * max(u01(key + uint(i) + 1u), 0.05));
        vec4 clip = view_proj * vec4(S, 1.0);
        if (clip.w <= 0.0) continue;
        vec2 px = (clip.xy / clip.w * 0.5 + 0.5) * vec2(size);  // pixel coordinates, y up
        ivec2 q = ivec2(floor(px));
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 Q = texelFetch(g_position, q, 0);
        if (Q.w < 0.5) continue;
        float r = distance(Q.xyz, P);
        if (distance(eye, Q.xyz) < distance(eye, S) && r < d_max)
            occ += quadratic == 1 ? 1.0 - (r * r) / (d_max * d_max) : 1.0;
    }
    imageStore(out_ao, p, vec4(1.0 - occ / float(samples)));
}
