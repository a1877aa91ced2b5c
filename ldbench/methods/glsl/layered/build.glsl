// Rasterize the scene into a layered structure (ldbench/methods/structures/sources.py): every fragment of both faces of
// every triangle, in every layer. One instance (gl_InstanceID) or one draw (layer_base) per layer; the
// layer's clip transform and depth row come from ls_layers. Depth test, culling and colour writes are
// off; no early_fragment_tests (nothing depth-tests here).
//
// Defines:
//   LS_LAYOUT 1 (linked lists) | 2 (linearised arrays)
//   LS_PASS_COUNT, LL_SORTED, LS_PAYLOAD, LS_PL_*: how a fragment is stored (layered/store.glsl)
//   LL_AGGREGATE    warp-aggregated node allocation (linked)
// Helper invocations (quad neighbours outside the triangle) must not write: their atomics have no effect
// and return undefined values, which would keep the CAS loop of the sorted insert spinning (llvmpipe runs
// them to its loop limit). gl_HelperInvocation: GLSL 4.50 / ARB_ES3_1_compatibility.
#extension GL_ARB_ES3_1_compatibility : enable
#include "layered/write.glsl"

#if defined(VERTEX_SHADER)
uniform int layer_base;
in vec3 in_position;
flat out uint v_layer;
out float v_depth;
#if LS_PAYLOAD > 0
in vec3 in_normal;
in float in_material;
flat out vec3 v_normal;
flat out uint v_material;
#endif
void main() {
    uint L = uint(layer_base + gl_InstanceID);
    vec4 p = vec4(in_position, 1.0);
    gl_Position = ls_layers[L].clip * p;
    v_depth = dot(ls_layers[L].depth_row, p);
    v_layer = L;
#if LS_PAYLOAD > 0
    v_normal = in_normal;
    v_material = uint(in_material + 0.5);
#endif
}

#elif defined(FRAGMENT_SHADER)
uniform ivec2 ls_size;      // W, H of one layer
uniform uint ls_capacity;   // nodes / fragments the structure holds
flat in uint v_layer;
in float v_depth;
#if LS_PAYLOAD > 0
flat in vec3 v_normal;
flat in uint v_material;
#endif
#include "layered/store.glsl"

void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    uint list = ls_list(v_layer, ivec2(gl_FragCoord.xy), ls_size);
#if LS_PAYLOAD > 0
    ls_store(list, v_depth, v_normal, v_material);
#else
    ls_store(list, v_depth, vec3(0.0), 0u);
#endif
}
#endif
