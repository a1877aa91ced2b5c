// Plain alpha blending (the speed baseline of yang2010 Fig. 4): every fragment of the scene (both faces, no
// depth test) in submission order, blended with (SRC_ALPHA, ONE_MINUS_SRC_ALPHA) on both targets:
//   target 0: (c, a)        C <- a c + (1 - a) C over the background the pass starts from
//   target 1: (1, 1, 1, 1)  alpha 1: the texel becomes 1 where any fragment lands (coverage)
// With BLEND_OPAQUE / BLEND_TRANSPARENT (parameter opaque_first): the pass keeps only the opaque (alpha 1) /
// transparent fragments.
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
flat in uint v_material;
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec4 out_cover;

void main() {
    vec4 m = oit_material[v_material];
#if defined(BLEND_OPAQUE)
    if (m.a < 1.0) discard;  // the opaque pass (opaque_first): depth-tested, writes depth
#elif defined(BLEND_TRANSPARENT)
    if (m.a >= 1.0) discard;  // the transparent pass: over the opaque surfaces, behind them hidden
#endif
    out_color = m;
    out_cover = vec4(1.0);
}
#endif
