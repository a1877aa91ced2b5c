// The planes a splat interpolates across a triangle in layer k, as the hardware does (layered/splat_raster.glsl,
// layered/splat_tiles.glsl): through the snapped vertices (SPLAT_SNAPPED_PLANE, NVIDIA) or the given ones, in the
// triangle's counter-clockwise order; the stored depth is dot(depth_row, p), clip z that of the clip matrix.
// Include after gbuffer/fill_rule.glsl and layered/layered.glsl.
#ifndef LDBENCH_SPLAT_PLANES_GLSL
#define LDBENCH_SPLAT_PLANES_GLSL
// value at a texel centre c: d0 + dot(dd, c - w0) (depth), z0 + dot(dz, c - w0) (clip z)
struct SpPlanes { vec2 w0; float d0, z0; vec2 dd, dz; };

// f0..f2: the snapped vertices counter-clockwise (1 and 2 swapped when cw); w, z, v: the window positions,
// clip z and world positions in the given order
SpPlanes sp_planes(uint k, bool cw, ivec2 f0, ivec2 f1, ivec2 f2, vec2 w0, vec2 w1, vec2 w2,
                   float z0, float z1, float z2, vec3 v0, vec3 v1, vec3 v2) {
    sp_plane_vertices(f0, f1, f2, cw, w0, w1, w2);
    if (cw) {
        float tz = z1; z1 = z2; z2 = tz;
        vec3 tv = v1; v1 = v2; v2 = tv;
    }
    vec4 row = ls_layers[k].depth_row;
    float d0 = dot(row, vec4(v0, 1.0)), d1 = dot(row, vec4(v1, 1.0)), d2 = dot(row, vec4(v2, 1.0));
    SpPlanes p;
    p.w0 = w0;
    p.d0 = d0;
    p.z0 = z0;
    p.dd = sp_plane_gradient(w0, w1, w2, d0, d1, d2);
    p.dz = sp_plane_gradient(w0, w1, w2, z0, z1, z2);
    return p;
}
#endif
