// Compaction of the peeled layers into the `linear` layout (layered/linear_arrays.glsl):
//   COMPACT_ENDS     la_off[i] = exclusive prefix sum of the layer counts + pl_count[i]: the end of list i
//                    (where list i + 1 begins), the convention of the one-pass build after its fill pass
//   COMPACT_SCATTER  scratch entry (texel, m, depth bits, triangle) -> slot la_begin(texel) + m: depth and
//                    payload words; the payload is looked up from the triangle id (face normal, material
//                    albedo), packed exactly as layered/build.glsl packs it from the vertex attributes.
#define LA_WRITABLE 1
#include "layered/layered.glsl"
#include "layered/ldi_common.glsl"
layout(local_size_x = 256) in;
uniform uint n;

#if defined(COMPACT_ENDS)
layout(std430, binding = B_PEEL_COUNT) readonly buffer PeelCount { uint pl_count[]; };
void main() {
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += stride) la_off[i] += pl_count[i];
}
#elif defined(COMPACT_SCATTER)
layout(std430, binding = B_PEEL_LOC) readonly buffer PeelLoc { uvec2 pl_loc[]; };
layout(std430, binding = B_PEEL_FRAG) readonly buffer PeelFrag { uvec2 pl_frag[]; };
layout(std430, binding = B_PEEL_VERTICES) readonly buffer Vertices { float vtx[]; };   // 3 x (position, normal, material)
#if defined(LS_PL_ALBEDO)
layout(std430, binding = B_LS_ALBEDO) readonly buffer LSAlbedo { vec4 ls_albedo[]; };
#endif
void main() {
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint e = gl_GlobalInvocationID.x; e < n; e += stride) {
        uvec2 loc = pl_loc[e], fr = pl_frag[e];
        uint slot = la_begin(loc.x) + loc.y;
        if (slot >= la_end(loc.x)) continue;   // cannot happen: m < count (checked by the invariants)
        la_depth[slot] = ldi_unorder(fr.x);
#if LS_PAYLOAD > 0
        uint base = fr.y * 21u;                // first vertex of the triangle, 7 floats per vertex
#if defined(LS_PL_NORMAL)
        vec3 nrm = vec3(vtx[base + 3u], vtx[base + 4u], vtx[base + 5u]);
        la_payload[slot * uint(LS_PAYLOAD) + uint(LS_PL_NORMAL)] = ls_pack_normal(normalize(nrm));
#endif
#if defined(LS_PL_ALBEDO)
        uint mat = uint(vtx[base + 6u] + 0.5);
        la_payload[slot * uint(LS_PAYLOAD) + uint(LS_PL_ALBEDO)] = packUnorm4x8(ls_albedo[mat]);
#endif
#if defined(LS_PL_MATERIAL)
        la_payload[slot * uint(LS_PAYLOAD) + uint(LS_PL_MATERIAL)] = uint(vtx[base + 6u] + 0.5);
#endif
#endif
    }
}
#endif
