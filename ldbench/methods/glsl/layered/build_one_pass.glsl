// One-pass multi-direction build of a layered structure (archer2019 §3.1; ldbench/methods/structures/sources.py
// build = "one_pass"): the scene is rasterized ONCE (per pass of layer_count layers), each triangle
// swizzled to its dominant axis, and every fragment is projected into each layer itself.
//
// Geometry shader: the triangle's face normal picks the dominant world axis (x, then y, then z on ties);
// the triangle is rasterized orthographically along that axis over the square [c - r, c + r]² of the
// bounding sphere (op_centre, op_radius), on the framebuffer's grid, so every triangle covers as many
// raster samples as it can (its projected area is at least 1/√3 of its area). Fragments carry their
// world position (interpolated linearly: the projection is orthographic).
// Fragment shader (Fig. 3 of the paper): for each layer k of [layer_base, layer_base + layer_count):
// clip = ls_layers[k].clip · p; the texel of the layer containing clip.xy / clip.w gets a fragment of
// depth dot(depth_row, p), unless p lies outside the layer's raster or depth range (|z| > w: the
// clipping a per-layer raster would do). The fragment's own position is stored, not the layer's texel
// centre: the raster is not conservative and not exact — a triangle more face-on to layer k than to
// its dominant axis leaves holes there, one seen edge-on gets extra fragments (the paper: "up to 25 %"
// more memory).
//
// Defines: as layered/build.glsl (LS_LAYOUT, LS_PASS_COUNT, LL_SORTED, LS_PAYLOAD / LS_PL_*,
// LL_AGGREGATE).
#extension GL_ARB_ES3_1_compatibility : enable
#include "layered/write.glsl"

#if defined(VERTEX_SHADER)
in vec3 in_position;
out vec3 vs_world;
#if LS_PAYLOAD > 0
in float in_material;
flat out uint vs_material;
#endif
void main() {
    vs_world = in_position;
#if LS_PAYLOAD > 0
    vs_material = uint(in_material + 0.5);
#endif
}

#elif defined(GEOMETRY_SHADER)
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
uniform vec3 op_centre;
uniform float op_radius;
in vec3 vs_world[];
out vec3 g_world;
#if LS_PAYLOAD > 0
flat in uint vs_material[];
flat out vec3 g_normal;
flat out uint g_material;
#endif
void main() {
    vec3 n = cross(vs_world[1] - vs_world[0], vs_world[2] - vs_world[0]);
    vec3 a = abs(n);
    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    for (int i = 0; i < 3; ++i) {
        vec3 q = (vs_world[i] - op_centre) / op_radius;
        vec2 xy = axis == 0 ? q.yz : (axis == 1 ? q.zx : q.xy);   // swizzle: the dominant axis becomes z
        gl_Position = vec4(xy, 0.0, 1.0);
        g_world = vs_world[i];
#if LS_PAYLOAD > 0
        g_normal = n;
        g_material = vs_material[0];
#endif
        EmitVertex();
    }
    EndPrimitive();
}

#elif defined(FRAGMENT_SHADER)
uniform ivec2 ls_size;      // W, H of one layer
uniform uint ls_capacity;   // nodes / fragments the structure holds
uniform uint layer_base;    // first layer of this pass
uniform uint layer_count;   // layers of this pass
in vec3 g_world;
#if LS_PAYLOAD > 0
flat in vec3 g_normal;
flat in uint g_material;
#endif
#include "layered/store.glsl"

void main() {
#if defined(GL_ARB_ES3_1_compatibility) || __VERSION__ >= 450
    if (gl_HelperInvocation) return;
#endif
    vec4 p = vec4(g_world, 1.0);
    for (uint k = layer_base; k < layer_base + layer_count; ++k) {
        vec4 c = ls_layers[k].clip * p;
        if (!(c.w > 0.0) || abs(c.z) > c.w) continue;
        vec2 f = (c.xy / c.w * 0.5 + 0.5) * vec2(ls_size);
        ivec2 px = ivec2(floor(f));
        if (any(lessThan(f, vec2(0.0))) || any(greaterThanEqual(px, ls_size))) continue;
        float depth = dot(ls_layers[k].depth_row, p);
#if LS_PAYLOAD > 0
        ls_store(ls_list(k, px, ls_size), depth, g_normal, g_material);
#else
        ls_store(ls_list(k, px, ls_size), depth, vec3(0.0), 0u);
#endif
    }
}
#endif
