// The orthographic layers that the ray tracers read (ldm_trace.glsl, cdi_trace.glsl, ldi_trace.glsl;
// ldbench/methods/structures/core.py ortho_layers and bind_ortho_layers). Layer k looks along v_k, with (u_k, w_k, v_k) a
// right-handed orthonormal basis, and covers the scene's bounding sphere (centre ol_centre, radius
// ol_radius) with ol_size texels: a point p lies at texel coordinates
// ((dot(p - c, u), dot(p - c, w)) / radius * 0.5 + 0.5) * size, at depth dot(p - c, v).
#ifndef LDBENCH_ORTHO_LAYERS_GLSL
#define LDBENCH_ORTHO_LAYERS_GLSL

struct OrthoAxis { vec4 u; vec4 w; vec4 v; };
layout(std430, binding = B_ORTHO_AXES) readonly buffer OrthoAxes { OrthoAxis ol_axes[]; };
uniform vec3 ol_centre;
uniform float ol_radius;
uniform ivec2 ol_size;

// The texel of layer k that contains p (clamped to the layer), p's offset to that texel's centre in world
// units along (u_k, w_k), and (returned) p's depth dot(p - c, v_k).
float ol_locate(uint k, vec3 p, out ivec2 px, out vec2 to_centre) {
    vec3 r = p - ol_centre;
    vec2 f = (vec2(dot(r, ol_axes[k].u.xyz), dot(r, ol_axes[k].w.xyz)) / ol_radius * 0.5 + 0.5) * vec2(ol_size);
    px = clamp(ivec2(floor(f)), ivec2(0), ol_size - 1);
    to_centre = (vec2(px) + 0.5 - f) * (2.0 * ol_radius / vec2(ol_size));
    return dot(r, ol_axes[k].v.xyz);
}

// The row of direction d's cell in ldbench/methods/directions.py nearest_axis_table(axes, res): the half cube's
// cell rule of cube_cell (major axis a, first of x, y, z on ties; d flipped to e[a] >= 0; the two other
// coordinates in order a+1, a+2 over e[a], in res x res squares).
int ol_table_row(vec3 d, int res) {
    vec3 ad = abs(d);
    int a = (ad.x >= ad.y && ad.x >= ad.z) ? 0 : (ad.y >= ad.z ? 1 : 2);
    vec3 e = d[a] >= 0.0 ? d : -d;
    vec2 uv = vec2(e[(a + 1) % 3], e[(a + 2) % 3]) / e[a];
    ivec2 ij = clamp(ivec2(floor((uv + 1.0) * 0.5 * float(res))), ivec2(0), ivec2(res - 1));
    return (a * res + ij.x) * res + ij.y;
}

#endif
