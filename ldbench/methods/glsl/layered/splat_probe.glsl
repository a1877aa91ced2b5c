// The hardware's raster rules, measured once per context (ldbench/methods/structures/splat.py fill_rule).
// probe_mode 0, the fill rule: triangles whose edges pass exactly through texel centres are rasterized
// into a small framebuffer and every covered texel records the bit of its primitive (gl_PrimitiveID).
// probe_mode 1, the interpolation rule: one triangle with vertices off the sub-pixel grid and a steep
// varying; every covered texel records the interpolated value, which tells whether the hardware's plane
// goes through the snapped or the given vertex positions. Vertices are given in window coordinates
// (texels; GL rows, y = 0 at the bottom).
#extension GL_ARB_ES3_1_compatibility : enable
#if defined(VERTEX_SHADER)
in vec2 in_position;
in float in_value;
out float v_value;
uniform vec2 probe_size;
void main() {
    v_value = in_value;
    gl_Position = vec4(in_position / probe_size * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined(FRAGMENT_SHADER)
layout(std430, binding = B_PROBE) buffer Probe { uint probe[]; };
in float v_value;
uniform int probe_width;
uniform int probe_mode;
void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    ivec2 p = ivec2(gl_FragCoord.xy);
    if (probe_mode == 1) probe[p.y * probe_width + p.x] = floatBitsToUint(v_value);
    else atomicOr(probe[p.y * probe_width + p.x], 1u << uint(gl_PrimitiveID));
}
#endif
