// GTAO's spatial denoise: one 3x3 edge-aware pass. Weights: the centre `beta`, edge neighbours 1,
// diagonal neighbours 0.5, each times exp(-(e / tol)^2), e the distance of the neighbour's world position
// from the centre pixel's tangent plane and tol = distance_to_eye / sharpness (scale-free), so AO is
// averaged along surfaces and never across depth edges. Background pixels are neither changed nor used.
// The workgroup first loads its 10 x 10 apron of positions and AO into shared memory: 1.6 texel fetches
// of each a pixel instead of 9 (the pass is bound by fetches of the 128-bit position texels).
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D in_ao;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform float beta;
uniform float sharpness;
uniform vec3 eye;

const int APRON = 10;                   // the 8 x 8 pixels and a one-pixel border
shared vec4 tile_pos[APRON * APRON];    // world position, w = 0 where no surface or off the image
shared float tile_ao[APRON * APRON];

void main() {
    ivec2 size = textureSize(g_position, 0);
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * 8 - 1;
    for (int i = int(gl_LocalInvocationIndex); i < APRON * APRON; i += 64) {
        ivec2 q = origin + ivec2(i % APRON, i / APRON);
        bool inside = all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, size));
        tile_pos[i] = inside ? texelFetch(g_position, q, 0) : vec4(0.0);
        tile_ao[i] = inside ? texelFetch(in_ao, q, 0).r : 0.0;
    }
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    ivec2 l = ivec2(gl_LocalInvocationID.xy) + 1;
    vec4 pos = tile_pos[l.y * APRON + l.x];
    float c = tile_ao[l.y * APRON + l.x];
    if (pos.w < 0.5) { imageStore(out_ao, p, vec4(c)); return; }
    vec3 n = texelFetch(g_normal, p, 0).xyz;
    float inv_tol = sharpness / max(distance(eye, pos.xyz), 1e-20);
    float wsum = beta, sum = beta * c;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0) continue;
            int j = (l.y + dy) * APRON + l.x + dx;
            vec4 s = tile_pos[j];
            if (s.w < 0.5) continue;
            float e = dot(s.xyz - pos.xyz, n) * inv_tol;
            float w = (dx != 0 && dy != 0 ? 0.5 : 1.0) * exp(-e * e);
            sum += w * tile_ao[j];
            wsum += w;
        }
    imageStore(out_ao, p, vec4(clamp(sum / wsum, 0.0, 1.0)));
}
