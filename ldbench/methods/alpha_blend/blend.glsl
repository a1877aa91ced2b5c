// Plain alpha blending (the speed baseline of yang2010 Fig. 4): every fragment of the scene (both faces, no
// depth test) in submission order, blended with (SRC_ALPHA, ONE_MINUS_SRC_ALPHA) on both targets:
//   target 0: (c, a)        C <- a c + (1 - a) C over the background the pass starts from
//   target 1: (1, 1, 1, 1)  alpha 1: the texel becomes 1 where any fragment lands (coverage)
#include "oit/oit.glsl"

#if defined(VERTEX_SHADER)
#include "oit/peel_vertex.glsl"

#elif defined(FRAGMENT_SHADER)
flat in uint v_material;
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec4 out_cover;

void main() {
    vec4 m = oit_material[v_material];
    out_color = m;
    out_cover = vec4(1.0);
}
#endif
