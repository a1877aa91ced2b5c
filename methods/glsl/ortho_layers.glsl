// The orthographic layers that the ray tracers read (ldm_trace.glsl, cdi_trace.glsl, ldi_trace.glsl;
// methods/layered.py ortho_layers and bind_ortho_layers). Layer k looks along v_k, with (u_k, w_k, v_k) a
// right-handed orthonormal basis, and covers the scene's bounding sphere (centre ol_centre, radius
// ol_radius) with ol_size texels: a point p lies at texel coordinates
// ((dot(p - c, u), dot(p - c, w)) / radius * 0.5 + 0.5) * size, at depth dot(p - c, v).
#ifndef LDBENCH_ORTHO_LAYERS_GLSL
#define LDBENCH_ORTHO_LAYERS_GLSL

struct OrthoAxis { vec4 u; vec4 w; vec4 v; };
layout(std430, binding = 11) readonly buffer OrthoAxes { OrthoAxis ol_axes[]; };
uniform vec3 ol_centre;
uniform float ol_radius;
uniform ivec2 ol_size;

#endif
