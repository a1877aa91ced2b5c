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
