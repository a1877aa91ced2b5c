// The hardware's fill rule in integer arithmetic, shared by the compute rasterizers: the splat build of
// the layered structures (layered/splat_raster.glsl) and the compute G-buffer (gbuffer/raster.glsl).
//
// Window coordinates are snapped to LS_SUBPIXEL_BITS of fixed point (round to nearest even); samples sit
// at texel centres; a sample exactly on an edge is covered only when the hardware includes that class of
// edge (SPLAT_TOP / BOTTOM / LEFT / RIGHT, 0 or 1, measured per context by layered/splat_probe.glsl,
// ldbench/methods/structures/splat.py fill_rule). With the triangle taken counter-clockwise (GL window
// coordinates, y up), a horizontal edge going left is a top edge, going right a bottom edge; an edge going
// down is a left edge, going up a right edge. sp_covers: callers keep coordinate differences below 2^14
// (edges of at most 64 texels) so every edge function fits int32; sp_covers_wide: fixed-point coordinates
// below 2^24 in magnitude, so every edge function is an exact double (products below 2^51).

const int SP_ONE = 1 << LS_SUBPIXEL_BITS;
const int SP_HALF = SP_ONE >> 1;

// 0 when a sample exactly on this edge (direction d, counter-clockwise triangle) is covered, else 1
int sp_bias(ivec2 d) {
    bool incl = d.y == 0 ? (d.x < 0 ? SPLAT_TOP != 0 : SPLAT_BOTTOM != 0)
                         : (d.y < 0 ? SPLAT_LEFT != 0 : SPLAT_RIGHT != 0);
    return incl ? 0 : 1;
}

// the edge function of the edge from f along e at the fixed-point sample p (covered: >= its sp_bias)
int sp_edge(ivec2 e, ivec2 f, ivec2 p) {
    return e.x * (p.y - f.y) - e.y * (p.x - f.x);
}

// the window-space gradient of the plane through (w_i, z_i), i = 0, 1, 2 (0 for a zero-area triangle): how the
// hardware interpolates depth and any other affine quantity across the triangle
vec2 sp_plane_gradient(vec2 w0, vec2 w1, vec2 w2, float z0, float z1, float z2) {
    vec2 A = w1 - w0, B = w2 - w0;
    float af = A.x * B.y - A.y * B.x;
    if (af == 0.0) return vec2(0.0);
    return vec2((z1 - z0) * B.y - (z2 - z0) * A.y, (z2 - z0) * A.x - (z1 - z0) * B.x) / af;
}

// texel centres i * ONE + HALF inside the fixed-point box [fmin, fmax], clamped to [0, size): i0 .. i1
// (arithmetic shifts: floor for negatives too); empty when any(greaterThan(i0, i1))
void sp_texel_box(ivec2 fmin, ivec2 fmax, ivec2 size, out ivec2 i0, out ivec2 i1) {
    i0 = max((fmin - SP_HALF + (SP_ONE - 1)) >> LS_SUBPIXEL_BITS, ivec2(0));
    i1 = min((fmax - SP_HALF) >> LS_SUBPIXEL_BITS, size - 1);
}

// A snapped triangle ready for sample tests: its fixed-point vertices in counter-clockwise order (1 and 2
// swapped when cw: the caller swaps its own per-vertex values alike), its edges and their biases.
struct SpTri { ivec2 f0, f1, f2, e0, e1, e2; int b0, b1, b2; };

SpTri sp_ccw(ivec2 f0, ivec2 f1, ivec2 f2, bool cw) {
    SpTri t;
    t.f0 = f0; t.f1 = cw ? f2 : f1; t.f2 = cw ? f1 : f2;
    t.e0 = t.f1 - t.f0; t.e1 = t.f2 - t.f1; t.e2 = t.f0 - t.f2;
    t.b0 = sp_bias(t.e0); t.b1 = sp_bias(t.e1); t.b2 = sp_bias(t.e2);
    return t;
}

// whether the centre of a texel is covered
bool sp_covers(SpTri t, ivec2 texel) {
    ivec2 p = texel * SP_ONE + SP_HALF;
    return sp_edge(t.e0, t.f0, p) >= t.b0 && sp_edge(t.e1, t.f1, p) >= t.b1 && sp_edge(t.e2, t.f2, p) >= t.b2;
}

// the window positions a plane is interpolated through, in the triangle's order: the snapped vertices
// f0..f2 (counter-clockwise, as SpTri's; SPLAT_SNAPPED_PLANE, exact: |f| < 2^24) or the given ones, 1 and 2
// swapped when cw
void sp_plane_vertices(ivec2 f0, ivec2 f1, ivec2 f2, bool cw, inout vec2 w0, inout vec2 w1, inout vec2 w2) {
#if SPLAT_SNAPPED_PLANE
    w0 = vec2(f0) / float(SP_ONE); w1 = vec2(f1) / float(SP_ONE); w2 = vec2(f2) / float(SP_ONE);
#else
    if (cw) { vec2 tw = w1; w1 = w2; w2 = tw; }
#endif
}

double sp_edge_wide(ivec2 e, ivec2 f, ivec2 p) {
    return double(e.x) * double(p.y - f.y) - double(e.y) * double(p.x - f.x);
}

// sp_covers for any triangle of sp_covers_wide's range (above)
bool sp_covers_wide(SpTri t, ivec2 texel) {
    ivec2 p = texel * SP_ONE + SP_HALF;
    return sp_edge_wide(t.e0, t.f0, p) >= double(t.b0) && sp_edge_wide(t.e1, t.f1, p) >= double(t.b1)
        && sp_edge_wide(t.e2, t.f2, p) >= double(t.b2);
}
