// The compute G-buffer's hardware path (ldbench/methods/gbuffer.py, raster = "compute"): the triangles the compute
// raster left (too large, or crossing the near or far plane, gbuffer/raster.glsl) drawn from its index
// list by one indirect draw into an attachment-less framebuffer; every fragment goes through the same
// visibility-buffer step as a computed one (gbuffer/vis.glsl) with the hardware's window depth.
#extension GL_ARB_ES3_1_compatibility : enable
#include "gbuffer/vis_ext.glsl"
#if defined(VERTEX_SHADER)
uniform mat4 view_proj;
in vec3 in_position;
flat out uint v_triangle;
void main() {
    v_triangle = uint(gl_VertexID) / 3u;   // indices 3t, 3t + 1, 3t + 2 of the non-indexed triangle list
    gl_Position = view_proj * vec4(in_position, 1.0);
}

#elif defined(FRAGMENT_SHADER)
#include "gbuffer/vis.glsl"
flat in uint v_triangle;
void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    vis_fragment(v_triangle, ivec2(gl_FragCoord.xy), gl_FragCoord.z);
}
#endif
