// The compute G-buffer's clipper (ldbench/methods/gbuffer.py, raster = "compute"), as the hardware clips: each
// triangle pass 0 listed in gcl_tri (crossing the near or far plane, or reaching beyond the fixed-point range)
// is clipped in clip space (Sutherland-Hodgman) against the near and far planes and a guard band
// |x|, |y| <= gb_guard() w, which keeps window coordinates within 2^15 pixels (half of GB_WIDE_LIMIT: the
// polygon's snapped vertices stay exact in gbuffer/fill_rule.glsl's double edge functions). The guard band's
// edges lie outside the viewport, so they decide no pixel; the near plane's edge is where the hardware's
// clipped triangle ends too. The convex polygon is recorded whole in gc_piece, set up for the tile raster
// (gbuffer/wide.glsl): its vertices snapped, counter-clockwise, its texel box and its depth plane. The
// hardware fans it into triangles whose inner edges share their pixels by the fill rule, so their union is
// the polygon; one polygon rather than a fan also keeps the tiles to one box. A triangle without room among
// clip_capacity records goes to the hardware.
//
// A pass of its own, an invocation per listed triangle: the clipper's arrays stay out of the registers of
// the per-triangle raster, which runs on every triangle. A point on a clipped edge is interpolated from the
// edge's inside vertex towards its outside one, so two triangles sharing that edge get the same point.
#include "gbuffer/vis_ext.glsl"
layout(local_size_x = 64) in;
#include "gbuffer/triangle.glsl"
#include "gbuffer/wide_list.glsl"
#include "gbuffer/lists.glsl"
uniform uint clip_capacity;   // entries of gc_piece

const int GB_CLIP_MAX = 9;   // 3 vertices, and at most one more per plane

float gb_guard() {
    return 0.5 * GB_WIDE_LIMIT / (0.5 * float(max(vis_size.x, vis_size.y))) - 1.0;
}

// plane k (near, far, left, right, bottom, top): >= 0 inside
float gb_plane(int k, vec4 c, float guard) {
    if (k == 0) return c.z + c.w;
    if (k == 1) return c.w - c.z;
    if (k == 2) return guard * c.w + c.x;
    if (k == 3) return guard * c.w - c.x;
    if (k == 4) return guard * c.w + c.y;
    return guard * c.w - c.y;
}

// the clipped polygon of c0 c1 c2 in poly[0 .. n), its winding kept; n = 0 when nothing is left
int gb_clip(vec4 c0, vec4 c1, vec4 c2, out vec4 poly[GB_CLIP_MAX]) {
    float guard = gb_guard();
    vec4 tmp[GB_CLIP_MAX];
    poly[0] = c0; poly[1] = c1; poly[2] = c2;
    int n = 3;
    for (int k = 0; k < 6 && n >= 3; ++k) {
        int m = 0;
        for (int i = 0; i < n; ++i) {
            vec4 a = poly[i], b = poly[i + 1 < n ? i + 1 : 0];
            float da = gb_plane(k, a, guard), db = gb_plane(k, b, guard);
            if (da >= 0.0) tmp[m++] = a;
            if ((da >= 0.0) != (db >= 0.0)) {
                vec4 p = da >= 0.0 ? a : b, q = da >= 0.0 ? b : a;
                float dp = max(da, db), dq = min(da, db);
                precise vec4 x = p + (dp / (dp - dq)) * (q - p);
                tmp[m++] = x;
            }
        }
        for (int i = 0; i < m; ++i) poly[i] = tmp[i];
        n = m;
    }
    return n >= 3 ? n : 0;
}

// The window depth plane of the triangle c0 c1 c2 (clip space), set up in double from its vertices as they are,
// not from the clipped polygon: z_ndc = a x_ndc + b y_ndc + d holds on the triangle's plane for any w != 0,
// so (a, b, d) solves the 3 x 3 system of its three vertices (x, y, w) (a, b, d) = z. A vertex that clipping
// puts on the near plane has z and w of about the near distance, each rounded to the float precision of the
// triangle's own coordinates: a depth plane through it was off by up to 384 steps of 2^-24 inside the
// viewport on llvmpipe (tests/test_gbuffer_compute.py), against 3 from the unclipped vertices.
// Returns (dz/dx, dz/dy) in window units and z at the window point o.
vec2 gb_depth_plane(vec4 c0, vec4 c1, vec4 c2, vec2 o, out float z_o) {
    dmat3 m = dmat3(dvec3(c0.x, c1.x, c2.x), dvec3(c0.y, c1.y, c2.y), dvec3(c0.w, c1.w, c2.w));
    dvec3 abd = inverse(m) * dvec3(c0.z, c1.z, c2.z);
    dvec2 hs = dvec2(vis_size) * 0.5;
    dvec2 ndc = (dvec2(o) - hs) / hs;
    z_o = float(0.5 * (abd.x * ndc.x + abd.y * ndc.y + abd.z) + 0.5);
    return vec2(0.5 * abd.xy / hs);
}

// Clips triangle t and records its polygon; to the hardware when it finds no room.
void gb_to_polygon(uint t) {
    vec4 c0, c1, c2, poly[GB_CLIP_MAX];
    gb_clip_coords(t, c0, c1, c2);
    int n = gb_clip(c0, c1, c2, poly);
    if (n == 0) return;
    vec2 hs = vec2(vis_size) * 0.5;
    ivec2 f[GB_CLIP_MAX];
    double area = 0.0;
    for (int i = 0; i < n; ++i) {
        vec2 w = poly[i].xy / poly[i].w * hs + hs;
        if (!(all(greaterThan(w, vec2(-GB_WIDE_LIMIT))) && all(lessThan(w, vec2(GB_WIDE_LIMIT))))) {
            gb_to_hardware(t);   // not finite
            return;
        }
        f[i] = ivec2(roundEven(w * float(SP_ONE)));
    }
    for (int i = 0; i < n; ++i) {   // the shoelace sum, exact in double (|f| < 2^24)
        ivec2 a = f[i], b = f[i + 1 < n ? i + 1 : 0];
        area += double(a.x) * double(b.y) - double(a.y) * double(b.x);
    }
    if (area == 0.0) return;
    ivec2 lo = f[0], hi = f[0];
    for (int i = 1; i < n; ++i) { lo = min(lo, f[i]); hi = max(hi, f[i]); }
    GbTri g;
    sp_texel_box(lo, hi, vis_size, g.i0, g.i1);
    if (any(greaterThan(g.i0, g.i1))) return;
    uint r = atomicAdd(gc_pieces, 1u);
    if (r >= clip_capacity) {
        gb_to_hardware(t);
        return;
    }
    GbPiece rec;
    vec2 o = 0.5 * vec2(g.i0 + g.i1 + 1);   // the box's centre
    float z_o;
    rec.dz = vec4(gb_depth_plane(c0, c1, c2, o, z_o), 0.0, 0.0);
    rec.plane = vec4(o, z_o, 0.0);
    rec.box = ivec4(g.i0, g.i1);
    rec.meta = uvec4(t, uint(n), 0u, 0u);
    for (int i = 0; i < 10; ++i) rec.f[i] = ivec2(0);
    for (int i = 0; i < n; ++i) rec.f[i] = f[area > 0.0 ? i : n - 1 - i];   // counter-clockwise
    gc_piece[r] = rec;
    gb_to_wide(r | GB_PIECE, g);
}

void main() {
    uint n = gcl_count;
    for (uint i = gl_GlobalInvocationID.x; i < n; i += gl_NumWorkGroups.x * 64u) gb_to_polygon(gcl_tri[i]);
}
