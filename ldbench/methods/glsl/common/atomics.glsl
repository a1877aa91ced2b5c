// Shared atomic helpers of the appending passes (linked-list inserts, pair emission).
#ifndef LDBENCH_ATOMICS_GLSL
#define LDBENCH_ATOMICS_GLSL
// RESULT = the old value of COUNTER after adding 1 for this invocation. With LL_AGGREGATE (ARB_shader_ballot)
// one atomicAdd per subgroup: its leader adds the number of active invocations, each takes base + its rank.
// A macro: GLSL cannot hand a buffer element to a function for an atomic. Used by every appending pass.
#if defined(LL_AGGREGATE)
// the invocations set in a subgroup mask
uint ls_count(uint64_t m) { uvec2 v = unpackUint2x32(m); return uint(bitCount(v.x) + bitCount(v.y)); }
// BASE = the old value of COUNTER after the first invocation of the mask LIVE (the active ones) added TOTAL
// (the same in each) for the subgroup; no atomic when TOTAL is 0
#define LS_SUBGROUP_ADD(COUNTER, LIVE, TOTAL, BASE) {                                      \
    uvec2 ls_m_ = unpackUint2x32(LIVE);                                                   \
    uint ls_leader_ = ls_m_.x != 0u ? uint(findLSB(ls_m_.x)) : 32u + uint(findLSB(ls_m_.y)); \
    uint ls_base_ = 0u;                                                                   \
    if (gl_SubGroupInvocationARB == ls_leader_ && (TOTAL) > 0u) ls_base_ = atomicAdd(COUNTER, TOTAL); \
    BASE = readInvocationARB(ls_base_, ls_leader_); }
#define LS_RESERVE(COUNTER, RESULT) {                                                     \
    uint64_t ls_live_ = ballotARB(true);                                                  \
    LS_SUBGROUP_ADD(COUNTER, ls_live_, ls_count(ls_live_), RESULT)                        \
    RESULT += ls_count(ls_live_ & gl_SubGroupLtMaskARB); }
#else
#define LS_RESERVE(COUNTER, RESULT) { RESULT = atomicAdd(COUNTER, 1u); }
#endif
#endif
