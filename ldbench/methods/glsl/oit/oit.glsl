// Shared GLSL of the OIT adapters (ldbench/methods/oit.py; effect ldbench/core/effects/oit.py).
//
//   oit_material[k]             vec4(albedo rgb, opacity) of material k (= mesh index), B_OIT_MATERIALS
//   oit_before(za, ma, zb, mb)  the effect's order: nearer depth first; at equal depth the lower material
//   oit_fullscreen(id)          clip position of vertex id of one triangle covering the viewport
//   OIT_FAR                     a depth beyond any surface (empty texels of the peeling methods)
#ifndef LDBENCH_OIT_GLSL
#define LDBENCH_OIT_GLSL

#define OIT_FAR 3.0e38

layout(std430, binding = B_OIT_MATERIALS) readonly buffer OITMaterials { vec4 oit_material[]; };

bool oit_before(float za, uint ma, float zb, uint mb) {
    return za < zb || (za == zb && ma < mb);
}

vec4 oit_fullscreen(int id) {
    return vec4(float((id & 1) << 2) - 1.0, float((id & 2) << 1) - 1.0, 0.0, 1.0);
}
#endif
