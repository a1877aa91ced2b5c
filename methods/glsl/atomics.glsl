// Shared atomic helpers of the appending passes (linked-list inserts, pair emission).
#ifndef LDBENCH_ATOMICS_GLSL
#define LDBENCH_ATOMICS_GLSL
// RESULT = the old value of COUNTER after adding 1 for this invocation. With LL_AGGREGATE (ARB_shader_ballot)
// one atomicAdd per subgroup: its leader adds the number of active invocations, each takes base + its rank.
// A macro: GLSL cannot hand a buffer element to a function for an atomic. Used by every appending pass.
#if defined(LL_AGGREGATE)
#define LS_RESERVE(COUNTER, RESULT) {                                                     \
    uint64_t ls_live_ = ballotARB(true);                                                  \
    uvec2 ls_m_ = unpackUint2x32(ls_live_);                                               \
    uvec2 ls_below_ = unpackUint2x32(ls_live_ & gl_SubGroupLtMaskARB);                    \
    uint ls_total_ = uint(bitCount(ls_m_.x) + bitCount(ls_m_.y));                         \
    uint ls_rank_ = uint(bitCount(ls_below_.x) + bitCount(ls_below_.y));                  \
    uint ls_leader_ = ls_m_.x != 0u ? uint(findLSB(ls_m_.x)) : 32u + uint(findLSB(ls_m_.y)); \
    uint ls_base_ = 0u;                                                                   \
    if (gl_SubGroupInvocationARB == ls_leader_) ls_base_ = atomicAdd(COUNTER, ls_total_); \
    RESULT = readInvocationARB(ls_base_, ls_leader_) + ls_rank_; }
#else
#define LS_RESERVE(COUNTER, RESULT) { RESULT = atomicAdd(COUNTER, 1u); }
#endif
#endif
