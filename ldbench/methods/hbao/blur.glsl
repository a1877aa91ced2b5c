// Depth-aware (cross-bilateral) separable blur of the AO image, one axis per dispatch.
//
// Weight of the sample at offset i along `axis`: exp(-i^2 / (2 sigma^2)) * exp(-(e / tol)^2), where e is
// the distance of the sample's world position from the centre pixel's tangent plane and tol =
// distance_to_eye / sharpness (a relative tolerance, independent of the scene's scale). Samples on
// the same plane (any slope) blend freely; samples across depth discontinuities do not. Background
// pixels are neither blurred nor used. sigma = (radius + 1) / 2, as in NVIDIA's HBAO blur.
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D in_ao;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform ivec2 axis;
uniform int radius;
uniform float sharpness;
uniform vec3 eye;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    float c = texelFetch(in_ao, p, 0).r;
    if (pos.w < 0.5 || radius <= 0) { imageStore(out_ao, p, vec4(c)); return; }
    vec3 n = texelFetch(g_normal, p, 0).xyz;
    float inv_tol = sharpness / max(distance(eye, pos.xyz), 1e-20);
    float sigma = 0.5 * float(radius + 1);
    float k = 1.0 / (2.0 * sigma * sigma);
    float wsum = 1.0, sum = c;
    for (int i = -radius; i <= radius; ++i) {
        if (i == 0) continue;
        ivec2 q = p + axis * i;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 s = texelFetch(g_position, q, 0);
        if (s.w < 0.5) continue;
        float e = dot(s.xyz - pos.xyz, n) * inv_tol;
        float w = exp(-float(i * i) * k - e * e);
        sum += w * texelFetch(in_ao, q, 0).r;
        wsum += w;
    }
    imageStore(out_ao, p, vec4(clamp(sum / wsum, 0.0, 1.0)));  // rounding may give 1 + 1 ulp
}
