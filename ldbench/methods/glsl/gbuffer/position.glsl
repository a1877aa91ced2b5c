// The G-buffer's world position of triangle t at pixel px, shared by the hardware pass (gbuffer/gbuffer.glsl) and the
// compute G-buffer's resolve (gbuffer/resolve.glsl), so that both rasters write the same bits: the camera ray
// through the pixel centre met with the triangle's plane, the sampling of the references' primary rays
// (Camera.primary_rays). Barycentrics b with sum(b_i (x, y, w)_i) parallel to (x_ndc, y_ndc, 1), from the
// unsnapped vertices: the hardware's own perspective-correct interpolation would use the vertices snapped
// to its sub-pixel grid, which moves the position off that ray (on NVIDIA by up to 2.4e-4 of the eye
// distance at grazing angles; tests/test_gbuffer_compute.py measures both against float64).
// geometry.vertices (ldbench/methods/gbuffer.py): per vertex position (3), face normal (3), material (1)
layout(std430, binding = B_GBUF_VERTICES) readonly buffer GbufVertices { float gb_vtx[]; };

vec3 gb_vertex(uint i) { return vec3(gb_vtx[7u * i], gb_vtx[7u * i + 1u], gb_vtx[7u * i + 2u]); }

vec3 gb_pixel_position(uint t, ivec2 px, ivec2 size, mat4 view_proj) {
    vec3 v0 = gb_vertex(3u * t), v1 = gb_vertex(3u * t + 1u), v2 = gb_vertex(3u * t + 2u);
    vec3 c0 = (view_proj * vec4(v0, 1.0)).xyw, c1 = (view_proj * vec4(v1, 1.0)).xyw;
    vec3 c2 = (view_proj * vec4(v2, 1.0)).xyw;
    vec3 q = vec3((vec2(px) + 0.5) / vec2(size) * 2.0 - 1.0, 1.0);
    precise vec3 b = vec3(dot(cross(c1, c2), q), dot(cross(c2, c0), q), dot(cross(c0, c1), q));
    b /= b.x + b.y + b.z;
    precise vec3 pos = b.x * v0 + b.y * v1 + b.z * v2;
    return pos;
}
