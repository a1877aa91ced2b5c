// Rasterize the scene into layered per-pixel linked lists (methods/linked_list.py).
// One instance (gl_InstanceID) or one draw (layer_base) per layer; the layer's clip transform and depth
// row come from the LLLayers buffer. Depth test, culling and colour writes are off: every fragment of
// both faces is inserted. No early_fragment_tests layout: nothing depth-tests here.
// Defines: LL_COUNT_ONLY (count fragments only), LL_SORTED (lock-free sorted insert, else yang2010),
// LL_AGGREGATE (warp-aggregated atomicAdd on the node counter).
// Helper invocations (quad neighbours outside the triangle) must not insert: their atomics have no
// effect and return undefined values, which would keep the CAS loop of the sorted insert spinning
// (llvmpipe runs them to its loop limit). gl_HelperInvocation: GLSL 4.50 / ARB_ES3_1_compatibility.
#extension GL_ARB_ES3_1_compatibility : enable
#if defined(LL_AGGREGATE)
#extension GL_ARB_shader_ballot : require
#extension GL_ARB_gpu_shader_int64 : require
#endif
#define LL_WRITABLE 1
#include "linked_list.glsl"

#if defined(VERTEX_SHADER)
uniform int layer_base;
in vec3 in_position;
flat out uint v_layer;
out float v_depth;
void main() {
    uint L = uint(layer_base + gl_InstanceID);
    vec4 p = vec4(in_position, 1.0);
    gl_Position = ll_layers[L].clip * p;
    v_depth = dot(ll_layers[L].depth_row, p);
    v_layer = L;
}

#elif defined(FRAGMENT_SHADER)
uniform ivec2 ll_size;      // W, H of one layer
uniform uint ll_capacity;   // nodes in the pool
flat in uint v_layer;
in float v_depth;
void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
#if defined(LL_COUNT_ONLY)
#if defined(LL_AGGREGATE)
    ll_alloc(0u);
#else
    atomicAdd(ll_counters[0], 1u);
#endif
#else
    uint list = ll_list_index(v_layer, ivec2(gl_FragCoord.xy), ll_size);
#if defined(LL_SORTED)
    ll_insert_sorted(list, v_depth, ll_capacity);
#else
    ll_insert_unsorted(list, v_depth, ll_capacity);
#endif
#endif
}
#endif
