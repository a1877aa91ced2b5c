// Depth peeling of every LDI at once (ldbench/methods/structures/peel.py): one instance per LDI, both faces, no depth
// test; a fragment's key is (depth, triangle id), depth as order-preserving uint bits (layered/ldi_common.glsl).
// Layer m of a texel is the smallest key strictly above layer m - 1's (pl_prev), found in two raster passes:
//   PEEL_PASS 1  the smallest depth among the fragments above pl_prev        (atomicMin on pl_cand.x)
//   PEEL_PASS 2  the smallest triangle id among those at exactly that depth  (atomicMin on pl_cand.y)
// so fragments at equal depth (coincident faces) are peeled one per layer instead of being lost, and
// every fragment of the one-pass build appears exactly once. The commit pass (layered/peel_commit.glsl) moves the
// candidates to pl_prev and appends them to the scratch list; its counter says when a pass found none.
// The vertex stage computes depth exactly as layered/build.glsl does, so both builds store equal floats.
#extension GL_ARB_ES3_1_compatibility : enable
#include "layered/layered.glsl"
#include "layered/ldi_common.glsl"

#if defined(VERTEX_SHADER)
in vec3 in_position;
flat out uint v_layer;
flat out uint v_prim;
out float v_depth;
void main() {
    uint L = uint(gl_InstanceID);
    vec4 p = vec4(in_position, 1.0);
    gl_Position = ls_layers[L].clip * p;
    v_depth = dot(ls_layers[L].depth_row, p);
    v_layer = L;
    v_prim = uint(gl_VertexID) / 3u;   // non-indexed triangle list: the triangle's index
}

#elif defined(FRAGMENT_SHADER)
uniform ivec2 ls_size;
flat in uint v_layer;
flat in uint v_prim;
in float v_depth;
layout(std430, binding = B_PEEL_PREV) coherent buffer PeelPrev { uvec2 pl_prev[]; };
layout(std430, binding = B_PEEL_CAND) coherent buffer PeelCand { uvec2 pl_cand[]; };

void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    uint list = la_list_index(v_layer, ivec2(gl_FragCoord.xy), ls_size);
    uint od = ldi_order(v_depth);
    uvec2 prev = pl_prev[list];
    bool above = od > prev.x || (od == prev.x && v_prim > prev.y);
#if PEEL_PASS == 1
    if (above) atomicMin(pl_cand[list].x, od);
#else
    if (above && od == pl_cand[list].x) atomicMin(pl_cand[list].y, v_prim);
#endif
}
#endif
