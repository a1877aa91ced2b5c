// The hardware's coverage of a triangle of any size in window coordinates (the photon splats: up to
// max_splat_px across, beyond the int32 range of gbuffer/fill_rule.glsl's edge functions): vertices snapped
// to LS_SUBPIXEL_BITS of fixed point, the edge functions evaluated in doubles (exact for any image size; over
// a tile, stepped from there in int32: fr_tile), the edge classes of gbuffer/fill_rule.glsl's sp_bias, zero area after snapping covering nothing.
#include "gbuffer/fill_rule.glsl"

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

bool fr_covers_at(ivec2 f0, ivec2 f1, ivec2 f2, ivec3 b, ivec2 pixel) {
    ivec2 p = pixel * SP_ONE + SP_HALF;
    return fr_edge(f0, f1, p) >= double(b.x) && fr_edge(f1, f2, p) >= double(b.y) && fr_edge(f2, f0, p) >= double(b.z);
}

bool fr_covers(FrTri t, ivec2 pixel) {
    return t.ok && fr_covers_at(t.f0, t.f1, t.f2, ivec3(t.b0, t.b1, t.b2), pixel);
}

// A triangle's edge functions over one tile of texels whose first texel is t0, for tests at many of its
// texels: c, each edge function at t0's centre less its bias, and the edges e; at texel t0 + d the edge
// function less its bias is c + e.x * d.y - e.y * d.x (d in sub-pixel steps), in int32. Exact: a c beyond
// +-2^30 is clamped, which no step within the tile can bring across zero while every edge component is at
// most lim (callers: 2^30 / (SP_ONE * (tile width + tile height))). A longer edge makes the triangle wide: it
// keeps its vertices (in e) and biases (in c) for the doubles of fr_covers_at. span: the last texel's d. full:
// it covers every texel centre of the tile; none: no texel centre (each from the edges' extremes over the tile;
// both false when wide). FR_NARROW: the caller has bounded every edge within lim, and the texel test leaves out
// the doubles of the wide case (their registers cost a tile's texel loop occupancy).
struct FrTile { ivec3 c; ivec2 e0, e1, e2; bool wide, full, none; };

int fr_clamp30(double v) { return int(clamp(v, -1073741824.0lf, 1073741824.0lf)); }

// the least and the greatest step of edge e over the tile (d from 0 to span)
ivec2 fr_step_range(ivec2 e, ivec2 span) {
    int a = e.x * span.y, b = -e.y * span.x;
    return ivec2(min(a, 0) + min(b, 0), max(a, 0) + max(b, 0));
}

// a FrTile's e for triangle t: its edges, or (wide) its vertices, for fr_covers_at
void fr_tile_edges(FrTri t, bool wide, out ivec2 e0, out ivec2 e1, out ivec2 e2) {
    if (wide) { e0 = t.f0; e1 = t.f1; e2 = t.f2; }
    else { e0 = t.f1 - t.f0; e1 = t.f2 - t.f1; e2 = t.f0 - t.f2; }
}

FrTile fr_tile(FrTri t, ivec2 t0, ivec2 span, int lim) {
    FrTile r;
    fr_tile_edges(t, false, r.e0, r.e1, r.e2);
    ivec2 m = max(max(abs(r.e0), abs(r.e1)), abs(r.e2));
    r.wide = max(m.x, m.y) > lim;
    r.full = false;
    r.none = false;
    if (r.wide) {
        r.c = ivec3(t.b0, t.b1, t.b2);
        fr_tile_edges(t, true, r.e0, r.e1, r.e2);
        return r;
    }
    ivec2 p = t0 * SP_ONE + SP_HALF;
    r.c = ivec3(fr_clamp30(fr_edge(t.f0, t.f1, p) - double(t.b0)), fr_clamp30(fr_edge(t.f1, t.f2, p) - double(t.b1)),
                fr_clamp30(fr_edge(t.f2, t.f0, p) - double(t.b2)));
    ivec2 s0 = fr_step_range(r.e0, span), s1 = fr_step_range(r.e1, span), s2 = fr_step_range(r.e2, span);
    r.full = r.c.x + s0.x >= 0 && r.c.y + s1.x >= 0 && r.c.z + s2.x >= 0;
    r.none = r.c.x + s0.y < 0 || r.c.y + s1.y < 0 || r.c.z + s2.y < 0;
    return r;
}

// whether texel t0 + d / SP_ONE (pixel) of the tile is covered
bool fr_tile_covers(FrTile r, ivec2 d, ivec2 pixel) {
#if !defined(FR_NARROW)
    if (r.wide) return fr_covers_at(r.e0, r.e1, r.e2, r.c, pixel);
#endif
    return r.c.x + r.e0.x * d.y - r.e0.y * d.x >= 0 && r.c.y + r.e1.x * d.y - r.e1.y * d.x >= 0 &&
           r.c.z + r.e2.x * d.y - r.e2.y * d.x >= 0;
}
