// GTAO's spatial denoise: one 3x3 edge-aware pass. Weights: the centre `beta`, edge neighbours 1,
// diagonal neighbours 0.5, each times exp(-(e / tol)^2), e the distance of the neighbour's world position
// from the centre pixel's tangent plane and tol = distance_to_eye / sharpness (scale-free), so AO is
// averaged along surfaces and never across depth edges. Background pixels are neither changed nor used.
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D in_ao;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform float beta;
uniform float sharpness;
uniform vec3 eye;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    float c = texelFetch(in_ao, p, 0).r;
    if (pos.w < 0.5) { imageStore(out_ao, p, vec4(c)); return; }
    vec3 n = texelFetch(g_normal, p, 0).xyz;
    float inv_tol = sharpness / max(distance(eye, pos.xyz), 1e-20);
    float wsum = beta, sum = beta * c;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0) continue;
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            vec4 s = texelFetch(g_position, q, 0);
            if (s.w < 0.5) continue;
            float e = dot(s.xyz - pos.xyz, n) * inv_tol;
            float w = (dx != 0 && dy != 0 ? 0.5 : 1.0) * exp(-e * e);
            sum += w * texelFetch(in_ao, q, 0).r;
            wsum += w;
        }
    imageStore(out_ao, p, vec4(clamp(sum / wsum, 0.0, 1.0)));
}
