// The layered-structure access interface (ldbench/methods/structures/): one GLSL API for every layout, so a
// tracer is written once and reads linked lists, linearised arrays and compacted depth-peeled layers.
//
//   LS_LAYOUT = 1  linked lists (yang2010; layered/linked_list.glsl)
//   LS_LAYOUT = 2  linearised arrays (archer2019; layered/linear_arrays.glsl); compacted depth-peeled layers
//                  (niessner2010) share this layout: a prefix sum over per-pixel counts, contiguous layers
//
//   uint  ls_list(layer, px, size)   list index of a texel (px in OpenGL rows: y = 0 at the bottom)
//   uint  ls_first(list)             first node of the list (nearest depth), or LS_END
//   uint  ls_next(list, node)        the next node, or LS_END (every walk is bounded: see ls_bound)
//   float ls_depth(node)             the node's depth (ascending along a list once built)
//   float ls_step(list, inout node)  the node's depth, and node moved to the next: one load of a linked node
//   uint  ls_payload(node, k)        payload word k < LS_PAYLOAD
//   uint  ls_bound()                 an upper bound of any list's length (loop guard)
//   uint  ls_count(list)             number of nodes (linear: O(1); linked: a bounded walk)
//
// Walk:  for (uint i = ls_first(l), s = 0u; i != LS_END && s < ls_bound(); i = ls_next(l, i), ++s) {...}
#ifndef LDBENCH_LAYERED_GLSL
#define LDBENCH_LAYERED_GLSL

#ifndef LS_LAYOUT
#define LS_LAYOUT 1
#endif
#define LS_END 0xFFFFFFFFu

// B_LAYERS: per-layer raster transform (the structure's set_layers)
struct LSLayer {
    mat4 clip;        // world -> clip space of the layer's raster
    vec4 depth_row;   // stored depth = dot(depth_row, vec4(p, 1))
};
layout(std430, binding = B_LAYERS) readonly buffer LSLayers { LSLayer ls_layers[]; };

#if LS_LAYOUT == 1
#include "layered/linked_list.glsl"
uint ls_list(uint layer, ivec2 px, ivec2 size) { return ll_list_index(layer, px, size); }
uint ls_first(uint list) { return ll_head[list]; }
uint ls_next(uint list, uint node) { return ll_next(node); }
float ls_depth(uint node) { return ll_depth(node); }
float ls_step(uint list, inout uint node) { LLNode n = ll_node(node); node = n.next; return n.depth; }
uint ls_bound() { return ll_capacity_bound(); }
#if LS_PAYLOAD > 0
uint ls_payload(uint node, uint k) { return ll_payload[node * uint(LS_PAYLOAD) + k]; }
#endif
uint ls_count(uint list) {
    uint n = 0u, b = ls_bound();
    for (uint i = ls_first(list); i != LS_END && n < b; i = ls_next(list, i)) ++n;
    return n;
}
#elif LS_LAYOUT == 2
#include "layered/linear_arrays.glsl"
uint ls_list(uint layer, ivec2 px, ivec2 size) { return la_list_index(layer, px, size); }
uint ls_first(uint list) { uint b = la_begin(list); return b < la_end(list) ? b : LS_END; }
uint ls_next(uint list, uint node) { return node + 1u < la_end(list) ? node + 1u : LS_END; }
float ls_depth(uint node) { return la_depth[node]; }
float ls_step(uint list, inout uint node) { float z = la_depth[node]; node = ls_next(list, node); return z; }
uint ls_bound() { return la_counters[LA_C_CAPACITY]; }
#if LS_PAYLOAD > 0
uint ls_payload(uint node, uint k) { return la_payload[node * uint(LS_PAYLOAD) + k]; }
#endif
uint ls_count(uint list) { return la_end(list) - la_begin(list); }
#else
#error "unknown LS_LAYOUT"
#endif

// ---- standard payload words (ldbench/methods/structures/spec.py PAYLOAD_WORDS): packing shared by builds and tracers ----
// normal: octahedral, 2 × snorm16; albedo: RGBA unorm8; material: the id as is.
vec2 ls_oct_wrap(vec2 v) { return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }
uint ls_pack_normal(vec3 n) {
    n /= (abs(n.x) + abs(n.y) + abs(n.z));
    vec2 e = n.z >= 0.0 ? n.xy : ls_oct_wrap(n.xy);
    return packSnorm2x16(e);
}
vec3 ls_unpack_normal(uint w) {
    vec2 e = unpackSnorm2x16(w);
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = ls_oct_wrap(n.xy);
    return normalize(n);
}
#endif
