// The hardware's coverage of a triangle of any size in window coordinates (the photon splats: up to
// max_splat_px across, beyond the int32 range of gbuffer_fill_rule.glsl's edge functions): vertices snapped
// to LS_SUBPIXEL_BITS of fixed point, the edge functions evaluated in doubles (exact for any image size),
// the edge classes of gbuffer_fill_rule.glsl's sp_bias, zero area after snapping covering nothing.
#include "gbuffer_fill_rule.glsl"

// f0..f2 counter-clockwise (1 and 2 swapped when cw); lo..hi: the texel centres of its box
struct FrTri { ivec2 f0, f1, f2; ivec2 lo, hi; int b0, b1, b2; bool ok, cw; };

FrTri fr_setup(vec2 w0, vec2 w1, vec2 w2, ivec2 size) {
    const float S = float(SP_ONE);
    FrTri t;
    t.f0 = ivec2(roundEven(w0 * S));
    t.f1 = ivec2(roundEven(w1 * S));
    t.f2 = ivec2(roundEven(w2 * S));
    ivec2 a = t.f1 - t.f0, b = t.f2 - t.f0;
    double area = double(a.x) * double(b.y) - double(a.y) * double(b.x);
    t.ok = area != 0.0lf;
    t.cw = area < 0.0lf;
    if (t.cw) { ivec2 s = t.f1; t.f1 = t.f2; t.f2 = s; }
    t.b0 = sp_bias(t.f1 - t.f0);
    t.b1 = sp_bias(t.f2 - t.f1);
    t.b2 = sp_bias(t.f0 - t.f2);
    sp_texel_box(min(t.f0, min(t.f1, t.f2)), max(t.f0, max(t.f1, t.f2)), size, t.lo, t.hi);  // clamped to size
    return t;
}

double fr_edge(ivec2 f, ivec2 g, ivec2 p) {
    ivec2 e = g - f;
    return double(e.x) * double(p.y - f.y) - double(e.y) * double(p.x - f.x);
}

bool fr_covers(FrTri t, ivec2 pixel) {
    ivec2 p = pixel * SP_ONE + SP_HALF;
    return t.ok && fr_edge(t.f0, t.f1, p) >= double(t.b0) && fr_edge(t.f1, t.f2, p) >= double(t.b1) &&
           fr_edge(t.f2, t.f0, p) >= double(t.b2);
}

// The edge functions of a triangle over a tile of texels t0 .. t1 (splat_tiles.glsl): their values at t0's
// centre and their steps per texel in x and y, exact in doubles. fr_tile is false when the triangle covers
// no centre of the tile by its box or because one edge excludes the whole tile (its largest value over the
// tile's centres is below its bias), so that a tile keeps only the long triangles that may cover it.
struct FrTile { dvec3 e0, sx, sy; ivec3 bias; };

// one edge f -> g at the tile's origin p (fixed point) and over its n texels: false when it excludes them all
bool fr_tile_edge(ivec2 f, ivec2 g, int bias, ivec2 p, dvec2 n, out double e0, out double sx, out double sy) {
    ivec2 e = g - f;
    e0 = fr_edge(f, g, p);
    sx = -double(e.y) * double(SP_ONE);
    sy = double(e.x) * double(SP_ONE);
    return e0 + max(sx * n.x, 0.0lf) + max(sy * n.y, 0.0lf) >= double(bias);
}

bool fr_tile(FrTri t, ivec2 t0, ivec2 t1, out FrTile r) {
    r.bias = ivec3(t.b0, t.b1, t.b2);
    if (!t.ok || any(greaterThan(max(t.lo, t0), min(t.hi, t1)))) return false;
    ivec2 p = t0 * SP_ONE + SP_HALF;
    dvec2 n = dvec2(t1 - t0);
    double a0, a1, a2, x0, x1, x2, y0, y1, y2;   // no vector indexing of doubles: NVIDIA's GLSL lacks it
    bool in0 = fr_tile_edge(t.f0, t.f1, t.b0, p, n, a0, x0, y0);
    bool in1 = fr_tile_edge(t.f1, t.f2, t.b1, p, n, a1, x1, y1);
    bool in2 = fr_tile_edge(t.f2, t.f0, t.b2, p, n, a2, x2, y2);
    r.e0 = dvec3(a0, a1, a2);
    r.sx = dvec3(x0, x1, x2);
    r.sy = dvec3(y0, y1, y2);
    return in0 && in1 && in2;
}

// whether the centre of texel t0 + d is covered (the same answer as fr_covers)
bool fr_tile_covers(FrTile r, ivec2 d) {
    dvec3 e = r.e0 + r.sx * double(d.x) + r.sy * double(d.y);
    return all(greaterThanEqual(e, dvec3(r.bias)));
}
