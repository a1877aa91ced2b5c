// Multi-layer alpha blending (Salvi & Vaidyanathan, I3D 2014), the insertion pass: every fragment of the
// scene (both faces, no depth test) is merged into its pixel's k-buffer of K layers, kept sorted by the
// effect's order (oit_before: depth, then material). A layer is (premultiplied colour C, transmittance
// T, depth, material). The fragment (c a, 1 - a) is inserted in order; when that makes K + 1 layers the
// two farthest merge into one: (C_a + T_a C_b, T_a T_b) at the nearer's depth, MLAB's compression.
//
// The read-modify-write of a pixel's layers is a critical section:
//   SYNC 1 (interlock): GL_ARB_fragment_shader_interlock, pixel_interlock_ordered: fragments of a pixel
//                       enter in primitive order, as the paper's pixel synchronization;
//   SYNC 0 (spinlock):  a per-pixel lock taken with atomicCompSwap, at most MAX_SPIN tries per fragment
//                       (a fragment that never gets it is counted in `lost`, never an endless loop);
//                       the order among a pixel's fragments is the GPU's.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
#if SYNC == 1
#extension GL_ARB_fragment_shader_interlock : require
layout(pixel_interlock_ordered) in;
#endif
layout(std430, binding = B_MLAB_LAYERS) coherent buffer MlabLayers { vec4 layer[]; };
layout(std430, binding = B_MLAB_KEYS) coherent buffer MlabKeys { vec2 key[]; };
layout(std430, binding = B_MLAB_COUNTS) coherent buffer MlabCounts { uint count[]; };
layout(std430, binding = B_MLAB_LOCKS) coherent buffer MlabLocks { uint lock_word[]; };
layout(std430, binding = B_MLAB_STATS) buffer MlabStats { uint fragments; uint lost; uint merges; uint pad; };
uniform ivec2 size;
in float v_depth;
flat in uint v_material;
layout(location = 0) out vec4 out_unused;

void insert(uint px) {
    uint base = px * uint(K), n = count[px];
    vec4 L[K + 1];
    vec2 Z[K + 1];
    for (uint i = 0u; i < n; ++i) { L[i] = layer[base + i]; Z[i] = key[base + i]; }
    vec4 m = oit_material[v_material];
    vec4 f = vec4(m.rgb * m.a, 1.0 - m.a);
    vec2 zf = vec2(v_depth, uintBitsToFloat(v_material));
    uint j = n;
    while (j > 0u && oit_before(zf.x, v_material, Z[j - 1u].x, floatBitsToUint(Z[j - 1u].y))) {
        L[j] = L[j - 1u]; Z[j] = Z[j - 1u]; --j;
    }
    L[j] = f; Z[j] = zf;
    ++n;
    if (n > uint(K)) {       // compress: merge the two farthest layers
        vec4 a = L[K - 1], b = L[K];
        L[K - 1] = vec4(a.rgb + a.a * b.rgb, a.a * b.a);
        n = uint(K);
        atomicAdd(merges, 1u);
    }
    for (uint i = 0u; i < n; ++i) { layer[base + i] = L[i]; key[base + i] = Z[i]; }
    count[px] = n;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    uint px = uint(p.y * size.x + p.x);
    atomicAdd(fragments, 1u);
#if SYNC == 1
    beginInvocationInterlockARB();
    insert(px);
    endInvocationInterlockARB();
#else
    bool done = false;
    for (int i = 0; i < MAX_SPIN && !done; ++i) {
        if (atomicCompSwap(lock_word[px], 0u, 1u) == 0u) {
            memoryBarrierBuffer();
            insert(px);
            memoryBarrierBuffer();
            atomicExchange(lock_word[px], 0u);
            done = true;
        }
    }
    if (!done) atomicAdd(lost, 1u);
#endif
    out_unused = vec4(0.0);
}
#endif
