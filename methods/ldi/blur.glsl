// The paper's optional screen-space filter of the indirect diffuse term (niessner2010 §5): a separable
// Gaussian of (2 radius + 1) taps, sigma = (radius + 1) / 2, over G-buffer pixels only (background is
// neither blurred nor used; no edge stopping, as in the paper). One axis per dispatch; with FINAL the
// result is multiplied by the pixel's albedo (indirect = a1 * blurred E). radius 0: FINAL only.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform sampler2D in_image;
uniform sampler2D g_position;
uniform sampler2D g_albedo;
uniform ivec2 axis;
uniform int radius;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_image);
    if (any(greaterThanEqual(p, size))) return;
    if (texelFetch(g_position, p, 0).w < 0.5) { imageStore(out_image, p, vec4(0.0)); return; }
    float sigma = 0.5 * float(radius + 1);
    float k = 1.0 / (2.0 * sigma * sigma);
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int i = -radius; i <= radius; ++i) {
        ivec2 q = p + axis * i;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        if (texelFetch(g_position, q, 0).w < 0.5) continue;
        float w = exp(-float(i * i) * k);
        sum += w * texelFetch(in_image, q, 0).rgb;
        wsum += w;
    }
    vec3 v = sum / wsum;
#if defined(FINAL)
    v *= texelFetch(g_albedo, p, 0).rgb;
#endif
    imageStore(out_image, p, vec4(v, 1.0));
}
