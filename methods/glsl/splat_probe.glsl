// The hardware fill rule, measured once per context (methods/layered_builds.py fill_rule): triangles
// whose edges pass exactly through texel centres are rasterized into a small framebuffer and every
// covered texel records the bit of its primitive (gl_PrimitiveID). Vertices are given in window
// coordinates (texels; GL rows, y = 0 at the bottom).
#extension GL_ARB_ES3_1_compatibility : enable
#if defined(VERTEX_SHADER)
in vec2 in_position;
uniform vec2 probe_size;
void main() { gl_Position = vec4(in_position / probe_size * 2.0 - 1.0, 0.0, 1.0); }

#elif defined(FRAGMENT_SHADER)
layout(std430, binding = 0) buffer Probe { uint probe[]; };
uniform int probe_width;
void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    ivec2 p = ivec2(gl_FragCoord.xy);
    atomicOr(probe[p.y * probe_width + p.x], 1u << uint(gl_PrimitiveID));
}
#endif
