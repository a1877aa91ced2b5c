// Per-pixel linked lists (yang2010 §3), N layers of W×H lists sharing one head buffer and one node pool:
// the "linked" layout of the layered-structure module (ldbench/methods/structures/core.py, ldbench/methods/structures/linked.py).
//
// Defines (ldbench/methods/structures/linked.py: LayeredLinkedLists.defines()):
//   LL_PAGES       1..4   number of SSBO pages the node pool is split into (SSBO size limits)
//   LL_PAGE_SHIFT         log2(nodes per page); node i lives in page i >> LL_PAGE_SHIFT
//   LS_PAYLOAD     0..8   payload words per node (a parallel buffer, read only on a hit)
//   LL_AGGREGATE          warp-aggregated node allocation (ARB_shader_ballot + ARB_gpu_shader_int64,
//                         enabled by the including shader)
//   LL_WRITABLE           passes that write lists (build, sort): buffers "coherent", writers defined
// Node layout: LLNode {float depth; uint next;} (8 bytes, one load per step of a walk); LL_EOL ends a list.
// Every walk is bounded by the pool capacity (ll_counters[LL_C_CAPACITY]): a corrupt link can never hang
// the GPU, it shows as a violated invariant (linked nodes != stored nodes).
#ifndef LDBENCH_LINKED_LIST_GLSL
#define LDBENCH_LINKED_LIST_GLSL

#ifndef LL_PAGES
#define LL_PAGES 1
#endif
#ifndef LL_PAGE_SHIFT
#define LL_PAGE_SHIFT 30
#endif
#ifndef LS_PAYLOAD
#define LS_PAYLOAD 0
#endif
#ifdef LL_WRITABLE
#define LL_QUAL coherent
#else
#define LL_QUAL readonly
#endif

#ifndef LL_MAX_RETRIES
#define LL_MAX_RETRIES 65536
#endif

#include "common/atomics.glsl"

#define LL_EOL 0xFFFFFFFFu
#define LL_PAGE_MASK ((1u << LL_PAGE_SHIFT) - 1u)

// B_COUNTERS: counters (indices shared with ldbench/methods/structures/linked.py)
#define LL_C_NODES 0u       // nodes handed out; saturates at the capacity (an overflowing alloc undoes its add)
#define LL_C_SORT_LONG 1u   // lists longer than LL_MAX_LIST met by the sort pass
#define LL_C_NONEMPTY 2u    // statistics pass: non-empty lists
#define LL_C_MAXLEN 3u      //   longest list
#define LL_C_UNSORTED 4u    //   lists out of order
#define LL_C_LINKED 5u      //   nodes reached from the heads (must equal the nodes stored)
#define LL_C_FAILED 6u      // sorted inserts abandoned (LL_MAX_RETRIES lost races, or a walk past the bound)
#define LL_C_OVERFLOW 7u    // fragments refused because the pool was full
#define LL_C_CAPACITY 8u    // pool capacity, written by the host: the bound of every list walk
// Passes that only read lists (tracers) see the counters as a plain readonly buffer: a coherent load of the
// walk bound in every step of every walk made tracing 100x slower on an H200 (docs/reference/rays.md).
#if defined(LL_WRITABLE) || defined(LL_STATS)
#define LL_COUNTERS_QUAL coherent
#else
#define LL_COUNTERS_QUAL readonly
#endif
layout(std430, binding = B_COUNTERS) LL_COUNTERS_QUAL buffer LLCounters { uint ll_counters[16]; };
layout(std430, binding = B_HEADS) LL_QUAL buffer LLHeads { uint ll_head[]; };

struct LLNode {
    float depth;
    uint next;
};
layout(std430, binding = B_NODES0) LL_QUAL buffer LLNodes0 { LLNode ll_nodes0[]; };
#if LL_PAGES > 1
layout(std430, binding = B_NODES1) LL_QUAL buffer LLNodes1 { LLNode ll_nodes1[]; };
#endif
#if LL_PAGES > 2
layout(std430, binding = B_NODES2) LL_QUAL buffer LLNodes2 { LLNode ll_nodes2[]; };
#endif
#if LL_PAGES > 3
layout(std430, binding = B_NODES3) LL_QUAL buffer LLNodes3 { LLNode ll_nodes3[]; };
#endif
#if LS_PAYLOAD > 0
layout(std430, binding = B_PAYLOAD) LL_QUAL buffer LLPayload { uint ll_payload[]; };
#endif

uint ll_capacity_bound() { return ll_counters[LL_C_CAPACITY]; }

// Node accessors: node i lives in page i >> LL_PAGE_SHIFT at index i & LL_PAGE_MASK.
LLNode ll_node(uint i) {
    LLNode r;
#if LL_PAGES == 1
    r = ll_nodes0[i];
#else
    uint p = i >> LL_PAGE_SHIFT, o = i & LL_PAGE_MASK;
    if (p == 0u) { r = ll_nodes0[o]; }
#if LL_PAGES > 2
    else if (p == 2u) { r = ll_nodes2[o]; }
#endif
#if LL_PAGES > 3
    else if (p == 3u) { r = ll_nodes3[o]; }
#endif
    else { r = ll_nodes1[o]; }
#endif
    return r;
}
float ll_depth(uint i) { return ll_node(i).depth; }
uint ll_next(uint i) {
    uint r;
#if LL_PAGES == 1
    r = ll_nodes0[i].next;
#else
    uint p = i >> LL_PAGE_SHIFT, o = i & LL_PAGE_MASK;
    if (p == 0u) { r = ll_nodes0[o].next; }
#if LL_PAGES > 2
    else if (p == 2u) { r = ll_nodes2[o].next; }
#endif
#if LL_PAGES > 3
    else if (p == 3u) { r = ll_nodes3[o].next; }
#endif
    else { r = ll_nodes1[o].next; }
#endif
    return r;
}

// Index of the list of layer `layer`, pixel `px` (row-major within a layer, OpenGL rows: y = 0 at the bottom).
uint ll_list_index(uint layer, ivec2 px, ivec2 size) {
    return (layer * uint(size.y) + uint(px.y)) * uint(size.x) + uint(px.x);
}

#ifdef LL_WRITABLE
// ---- writers ---------------------------------------------------------------------------------------
void ll_set_node(uint i, float z, uint n) {
#if LL_PAGES == 1
    ll_nodes0[i] = LLNode(z, n);
#else
    uint p = i >> LL_PAGE_SHIFT, o = i & LL_PAGE_MASK;
    if (p == 0u) { ll_nodes0[o] = LLNode(z, n); }
#if LL_PAGES > 2
    else if (p == 2u) { ll_nodes2[o] = LLNode(z, n); }
#endif
#if LL_PAGES > 3
    else if (p == 3u) { ll_nodes3[o] = LLNode(z, n); }
#endif
    else { ll_nodes1[o] = LLNode(z, n); }
#endif
}
void ll_set_depth(uint i, float z) {
#if LL_PAGES == 1
    ll_nodes0[i].depth = z;
#else
    uint p = i >> LL_PAGE_SHIFT, o = i & LL_PAGE_MASK;
    if (p == 0u) { ll_nodes0[o].depth = z; }
#if LL_PAGES > 2
    else if (p == 2u) { ll_nodes2[o].depth = z; }
#endif
#if LL_PAGES > 3
    else if (p == 3u) { ll_nodes3[o].depth = z; }
#endif
    else { ll_nodes1[o].depth = z; }
#endif
}
// atomicCompSwap on node i's next pointer; returns the value found there.
uint ll_cas_next(uint i, uint expected, uint value) {
    uint r;
#if LL_PAGES == 1
    r = atomicCompSwap(ll_nodes0[i].next, expected, value);
#else
    uint p = i >> LL_PAGE_SHIFT, o = i & LL_PAGE_MASK;
    if (p == 0u) { r = atomicCompSwap(ll_nodes0[o].next, expected, value); }
#if LL_PAGES > 2
    else if (p == 2u) { r = atomicCompSwap(ll_nodes2[o].next, expected, value); }
#endif
#if LL_PAGES > 3
    else if (p == 3u) { r = atomicCompSwap(ll_nodes3[o].next, expected, value); }
#endif
    else { r = atomicCompSwap(ll_nodes1[o].next, expected, value); }
#endif
    return r;
}
#if LS_PAYLOAD > 0
void ll_set_payload(uint i, uint w[LS_PAYLOAD]) {
    for (uint k = 0u; k < uint(LS_PAYLOAD); ++k) ll_payload[i * uint(LS_PAYLOAD) + k] = w[k];
}
#endif

// Take the next node index.
uint ll_reserve() {
    uint n;
    LS_RESERVE(ll_counters[LL_C_NODES], n)
    return n;
}

// Allocate a node; LL_EOL when the pool is full. An allocation past the capacity undoes its add and
// counts itself in LL_C_OVERFLOW, so the node counter never runs past capacity + the fragments in
// flight: it cannot wrap around 2^32 and hand out live nodes again, however many fragments arrive.
uint ll_claim(uint n, uint capacity) {   // node n: taken from the counter for this invocation (ll_reserve, or its share of a subgroup's bulk add)
    if (n < capacity) return n;
    atomicAdd(ll_counters[LL_C_NODES], 0xFFFFFFFFu);   // undo: saturate at the capacity
    atomicAdd(ll_counters[LL_C_OVERFLOW], 1u);
    return LL_EOL;
}
uint ll_alloc(uint capacity) { return ll_claim(ll_reserve(), capacity); }

// yang2010 insert: push at the head with atomicExchange (lists come out in arbitrary order).
uint ll_insert_unsorted(uint list, float z, uint capacity) {
    uint n = ll_alloc(capacity);
    if (n == LL_EOL) return n;
    uint old = atomicExchange(ll_head[list], n);
    ll_set_node(n, z, old);       // read only after the pass (memory barrier between passes)
    return n;
}

// Lock-free sorted insert (ascending depth): walk to the first node with depth >= z, link the new
// node in front of it and publish it with atomicCompSwap on the predecessor's pointer (or the head).
// If the CAS fails, another fragment was linked in right there: continue the walk from the same
// predecessor, starting at the node the CAS found. Correct because nodes are only ever inserted (a
// predecessor stays valid and stays before z), and lock-free: a failed CAS means another insert won.
// Returns the node (LL_EOL when the pool is full or the insert was abandoned).
uint ll_insert_sorted(uint list, float z, uint capacity) {
    uint n = ll_alloc(capacity);
    if (n == LL_EOL) return n;
    uint prev = LL_EOL;            // LL_EOL = the head pointer is the predecessor's slot
    uint cur = atomicOr(ll_head[list], 0u);
    uint steps = 0u;
    for (uint attempt = 0u; attempt < uint(LL_MAX_RETRIES); ++attempt) {
        while (cur != LL_EOL && steps < capacity) {
            LLNode c = ll_node(cur);
            if (c.depth >= z) break;
            prev = cur;
            cur = c.next;
            ++steps;
        }
        if (steps >= capacity) break;  // longer than the pool: a corrupt list; never spin on it
        ll_set_node(n, z, cur);
        memoryBarrierBuffer();     // the node is visible before it is published
        uint seen = (prev == LL_EOL) ? atomicCompSwap(ll_head[list], cur, n) : ll_cas_next(prev, cur, n);
        if (seen == cur) return n;
        cur = seen;
    }
    atomicAdd(ll_counters[LL_C_FAILED], 1u); // not linked: reported (degraded row), never silent
    return LL_EOL;
}
#endif  // LL_WRITABLE

#endif
