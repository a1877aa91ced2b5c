// The paper's optional screen-space filter of the indirect diffuse term (niessner2010 §5): a separable
// Gaussian of (2 radius + 1) taps, sigma = (radius + 1) / 2, over G-buffer pixels only (background is
// neither blurred nor used; no edge stopping, as in the paper). One axis per dispatch; with FINAL the
// result is multiplied by the pixel's albedo (indirect = a1 * blurred E). radius 0: FINAL only.
// BILATERAL (filter_kind = bilateral, not in the paper): each tap's weight is also multiplied by
// exp(-(e / tol)^2) · max(n · n_q, 0)^NORMAL_POWER, e the distance of the tap's position from the centre
// pixel's tangent plane, tol = distance to the eye / sharpness (the plane weight of ldbench/methods/hbao/blur.glsl),
// n, n_q the normals: light is not mixed across depth edges (plane term) and creases (normal term: near a
// crease the other surface is within the plane tolerance), where E differs.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform sampler2D in_image;
uniform sampler2D g_position;
uniform sampler2D g_albedo;
uniform ivec2 axis;
uniform int radius;
#if defined(BILATERAL)
uniform sampler2D g_normal;
uniform vec3 eye;
uniform float sharpness;
#define NORMAL_POWER 8.0
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_image);
    if (any(greaterThanEqual(p, size))) return;
    if (texelFetch(g_position, p, 0).w < 0.5) { imageStore(out_image, p, vec4(0.0)); return; }
#if defined(BILATERAL)
    vec3 pc = texelFetch(g_position, p, 0).xyz, nc = texelFetch(g_normal, p, 0).xyz;  // the tangent plane
    float inv_tol = sharpness / max(distance(eye, pc), 1e-20);
#endif
    float sigma = 0.5 * float(radius + 1);
    float k = 1.0 / (2.0 * sigma * sigma);
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int i = -radius; i <= radius; ++i) {
        ivec2 q = p + axis * i;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 s = texelFetch(g_position, q, 0);
        if (s.w < 0.5) continue;
        float w = exp(-float(i * i) * k);
#if defined(BILATERAL)
        float e = dot(s.xyz - pc, nc) * inv_tol;
        float c = max(dot(nc, texelFetch(g_normal, q, 0).xyz), 0.0);
        w *= exp(-e * e) * pow(c, NORMAL_POWER);
#endif
        sum += w * texelFetch(in_image, q, 0).rgb;
        wsum += w;
    }
    vec3 v = sum / wsum;
#if defined(FINAL)
    v *= texelFetch(g_albedo, p, 0).rgb;
#endif
    imageStore(out_image, p, vec4(v, 1.0));
}
