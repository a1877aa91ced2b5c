// Store one fragment in a layered structure: the write side of every build (ldbench/methods/structures/), shared
// by the per-layer raster (layered/build.glsl) and the one-pass multi-direction raster
// (layered/build_one_pass.glsl). Include after layered/layered.glsl, with LL_WRITABLE / LA_WRITABLE defined.
//
//   void ls_store(uint list, float depth, vec3 normal, uint material)
//
// LS_PASS_COUNT   count only: linked = the total (pool sizing), linear = per list (la_off[list]++)
// LS_EMIT         linear, sort assembly (ldbench/methods/structures/linear.py): append (list, depth, payload) to the
//                 pairs (B_PAIRS; one atomicAdd per subgroup with LL_AGGREGATE) and count la_off[list]++
// otherwise       linked: insert (LL_SORTED: lock-free sorted insert, else yang2010's atomicExchange);
//                 linear: fill (slot = atomicAdd(la_off[list], 1))
// Payload words (LS_PAYLOAD > 0; LS_PL_NORMAL / LS_PL_ALBEDO / LS_PL_MATERIAL = the word index of each):
// normal and material are ignored without payload. The caller discards helper invocations.
#ifndef LDBENCH_LAYERED_STORE_GLSL
#define LDBENCH_LAYERED_STORE_GLSL

#if LS_PAYLOAD > 0 && defined(LS_PL_ALBEDO)
layout(std430, binding = B_LS_ALBEDO) readonly buffer LSAlbedo { vec4 ls_albedo[]; };
#endif

#if defined(LS_EMIT) && LS_LAYOUT == 2
#define LS_PAIR_WORDS (2 + LS_PAYLOAD)
layout(std430, binding = B_PAIRS) writeonly buffer LSPairs { uint ls_pairs[]; };
#include "common/atomics.glsl"
uint ls_reserve_pair() {   // next pair slot
    uint n;
    LS_RESERVE(la_counters[LA_C_EMITTED], n)
    return n;
}
#endif

#if LS_PAYLOAD > 0
// the payload words of a fragment
void ls_payload_words(vec3 normal, uint material, out uint w[LS_PAYLOAD]) {
    for (int k = 0; k < LS_PAYLOAD; ++k) w[k] = 0u;
#if defined(LS_PL_NORMAL)
    w[LS_PL_NORMAL] = ls_pack_normal(normalize(normal));
#endif
#if defined(LS_PL_ALBEDO)
    w[LS_PL_ALBEDO] = packUnorm4x8(ls_albedo[material]);
#endif
#if defined(LS_PL_MATERIAL)
    w[LS_PL_MATERIAL] = material;
#endif
}
#endif

void ls_store(uint list, float depth, vec3 normal, uint material) {
#if defined(LS_PASS_COUNT)
#if LS_LAYOUT == 1
    ll_reserve();                  // the total only (pool sizing); no node is written
#else
    atomicAdd(la_off[list], 1u);
#endif
#else
#if LS_PAYLOAD > 0
    uint w[LS_PAYLOAD];
    ls_payload_words(normal, material, w);
#endif
#if LS_LAYOUT == 1
#if defined(LL_SORTED)
    uint n = ll_insert_sorted(list, depth, ls_capacity);
#else
    uint n = ll_insert_unsorted(list, depth, ls_capacity);
#endif
#if LS_PAYLOAD > 0
    if (n != LL_EOL) ll_set_payload(n, w);
#endif
#elif defined(LS_EMIT)
    uint slot = ls_reserve_pair();
    if (slot < ls_capacity) {
        atomicAdd(la_off[list], 1u);   // only stored pairs are counted: the offsets match the scatter
        uint s = slot * uint(LS_PAIR_WORDS);
        ls_pairs[s] = list;
        ls_pairs[s + 1u] = floatBitsToUint(depth);
#if LS_PAYLOAD > 0
        for (int k = 0; k < LS_PAYLOAD; ++k) ls_pairs[s + 2u + uint(k)] = w[k];
#endif
    } else {
        atomicAdd(la_counters[LA_C_OVERFLOW], 1u);
    }
#else
    uint slot = atomicAdd(la_off[list], 1u);
    if (slot < ls_capacity) {
        la_depth[slot] = depth;
#if LS_PAYLOAD > 0
        for (int k = 0; k < LS_PAYLOAD; ++k) la_payload[slot * uint(LS_PAYLOAD) + uint(k)] = w[k];
#endif
    } else {
        atomicAdd(la_counters[LA_C_OVERFLOW], 1u);
    }
#endif
#endif
}
#endif
