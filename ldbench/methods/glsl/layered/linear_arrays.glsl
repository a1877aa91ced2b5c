// Linearised per-pixel arrays (archer2019 §3; pknowles' "linearised" fragment buffer): the "linear"
// layout of the layered-structure module (ldbench/methods/structures/core.py, ldbench/methods/structures/linear.py).
//
// The fragments of list i are contiguous: la_depth[begin(i) .. end(i)), sorted by ascending depth after
// the sort pass. Build: count pass (atomicAdd on la_off[i]), exclusive prefix sum of la_off over all
// n lists (+ 1: la_off[n] = total), fill pass (slot = atomicAdd(la_off[i], 1): afterwards la_off[i]
// holds the END of list i, which is where list i + 1 begins, so begin(i) = i > 0 ? la_off[i - 1] : 0 and
// no second offset array is needed), per-list sort.
//
// Defines: LS_PAYLOAD (payload words per fragment), LA_WRITABLE (build/sort passes).
#ifndef LDBENCH_LINEAR_ARRAYS_GLSL
#define LDBENCH_LINEAR_ARRAYS_GLSL

#ifndef LS_PAYLOAD
#define LS_PAYLOAD 0
#endif
#ifdef LA_WRITABLE
#define LA_QUAL coherent
#else
#define LA_QUAL readonly
#endif

// B_COUNTERS: counters (indices shared with ldbench/methods/structures/linear.py)
#define LA_C_COUNTED 0u     // fragments of the count pass
#define LA_C_SORT_LONG 1u   // lists longer than LA_MAX_LIST met by the sort pass (sorted in global memory)
#define LA_C_NONEMPTY 2u    // statistics pass: non-empty lists
#define LA_C_MAXLEN 3u      //   longest list
#define LA_C_UNSORTED 4u    //   lists out of order
#define LA_C_FILLED 5u      // fragments written by the fill pass (must equal the count)
#define LA_C_EMITTED 6u     // sort assembly: fragments appended as pairs, stored or not
#define LA_C_OVERFLOW 7u    // fill-pass fragments beyond the capacity (never with the "grow" policy)
#define LA_C_CAPACITY 8u    // fragments the depth buffer holds (host-written)
#if defined(LA_WRITABLE) || defined(LA_STATS)   // readers: a plain cached load (see layered/linked_list.glsl)
#define LA_COUNTERS_QUAL coherent
#else
#define LA_COUNTERS_QUAL readonly
#endif
layout(std430, binding = B_COUNTERS) LA_COUNTERS_QUAL buffer LACounters { uint la_counters[16]; };
layout(std430, binding = B_HEADS) LA_QUAL buffer LAOffsets { uint la_off[]; };

layout(std430, binding = B_NODES0) LA_QUAL buffer LADepth { float la_depth[]; };
#if LS_PAYLOAD > 0
layout(std430, binding = B_PAYLOAD) LA_QUAL buffer LAPayload { uint la_payload[]; };
#endif

// Clamped to the capacity: with a "fixed" pool that overflowed, slots past it were never written.
uint la_begin(uint list) { return list == 0u ? 0u : min(la_off[list - 1u], la_counters[LA_C_CAPACITY]); }
uint la_end(uint list) { return min(la_off[list], la_counters[LA_C_CAPACITY]); }

uint la_list_index(uint layer, ivec2 px, ivec2 size) {
    return (layer * uint(size.y) + uint(px.y)) * uint(size.x) + uint(px.x);
}

#endif
