// GTAO's depth pre-filter (XeGTAO's PrefilterDepths16x16): the view-space depth of every pixel and four
// coarser MIP levels, in one dispatch. Each invocation of an 8x8 group takes a 2x2 quad of pixels, so a
// group writes a 16x16 block of level 0 and its 8x8, 4x4, 2x2 and 1x1 blocks of levels 1..4 (the texture
// is padded to a multiple of 16 pixels, so every level is exactly half the one before).
//
// Depth = -z in view space, 0 for background (and the padding). A coarser texel is XeGTAO's weighted
// average of its four finer ones (XeGTAO_DepthMIPFilter): the farthest of them has weight 1, a nearer one
// weight clamp(1 - (x - from) / range, 0, 1), x its distance in front of the farthest, R = 0.75 d_max
// (XeGTAO's depthRangeScaleFactor times the effect radius), range = 0.615 R and from = R - range (XeGTAO's
// FalloffRange): a thin occluder far in front of what lies behind it fades out of the coarse levels.
// filter_radius <= 0 (d_max = inf): every weight is 1, the plain mean. Background texels are left out;
// a texel with no foreground at all is background.
// DEPTH16 1: levels 1..4 go to a 16-bit texture of half the size (out_depth1..4 its levels 0..3); the
// filter itself runs in 32-bit floats on the 32-bit level-0 depths.
#ifndef DEPTH16
#define DEPTH16 0
#endif
#if DEPTH16
#define MIP_FORMAT r16f
#else
#define MIP_FORMAT r32f
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_GTAO_DEPTH0) writeonly uniform image2D out_depth0;
layout(MIP_FORMAT, binding = B_GTAO_DEPTH1) writeonly uniform image2D out_depth1;
layout(MIP_FORMAT, binding = B_GTAO_DEPTH2) writeonly uniform image2D out_depth2;
layout(MIP_FORMAT, binding = B_GTAO_DEPTH3) writeonly uniform image2D out_depth3;
layout(MIP_FORMAT, binding = B_GTAO_DEPTH4) writeonly uniform image2D out_depth4;
uniform sampler2D g_position;   // world position, w = 1 where hit
uniform mat4 view;              // world -> view (rigid)
uniform float filter_radius;    // 0.75 d_max; <= 0 for d_max = inf

shared float scratch[8][8];

float view_depth(ivec2 p) {
    if (any(greaterThanEqual(p, textureSize(g_position, 0)))) return 0.0;  // padding
    vec4 pos = texelFetch(g_position, p, 0);
    return pos.w < 0.5 ? 0.0 : -(view * vec4(pos.xyz, 1.0)).z;
}

float mip_filter(vec4 d) {
    vec4 valid = vec4(greaterThan(d, vec4(0.0)));
    float far = max(max(d.x, d.y), max(d.z, d.w));
    if (far <= 0.0) return 0.0;
    vec4 w = valid;
    if (filter_radius > 0.0) {
        float range = 0.615 * filter_radius, from = filter_radius - range;
        w *= clamp(1.0 - ((far - d) - from) / range, 0.0, 1.0);
    }
    return dot(w, d) / dot(w, vec4(1.0));
}

void main() {
    ivec2 g = ivec2(gl_GlobalInvocationID.xy), l = ivec2(gl_LocalInvocationID.xy);
    ivec2 p = 2 * g;
    vec4 d = vec4(view_depth(p), view_depth(p + ivec2(1, 0)), view_depth(p + ivec2(0, 1)),
                  view_depth(p + ivec2(1, 1)));
    imageStore(out_depth0, p, vec4(d.x));
    imageStore(out_depth0, p + ivec2(1, 0), vec4(d.y));
    imageStore(out_depth0, p + ivec2(0, 1), vec4(d.z));
    imageStore(out_depth0, p + ivec2(1, 1), vec4(d.w));
    float m = mip_filter(d);
    imageStore(out_depth1, g, vec4(m));
    scratch[l.x][l.y] = m;
    memoryBarrierShared();
    barrier();
    for (int level = 2, s = 1; level <= 4; ++level, s *= 2) {
        bool writes = all(equal(l % (2 * s), ivec2(0)));
        if (writes) {
            m = mip_filter(vec4(scratch[l.x][l.y], scratch[l.x + s][l.y], scratch[l.x][l.y + s],
                                scratch[l.x + s][l.y + s]));
            ivec2 t = g / (2 * s);
            if (level == 2) imageStore(out_depth2, t, vec4(m));
            else if (level == 3) imageStore(out_depth3, t, vec4(m));
            else imageStore(out_depth4, t, vec4(m));
        }
        barrier();
        if (writes) scratch[l.x][l.y] = m;
        memoryBarrierShared();
        barrier();
    }
}
