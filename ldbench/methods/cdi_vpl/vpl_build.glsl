// "Build VPL buffer" (archer2019 §3.2): one invocation per VPL, the RSM texel (step · jx, step · jy) (step =
// vpl_step: every step-th texel in x and y, its flux and area × step²). A texel with a surface inside the
// cone is a VPL {position, range; normal, area; flux}; range 0 marks none. The range:
//   VPL_RANGE_CDI     six rays through the CDI (vpl.glsl, cdi_trace.glsl), mean or max of min(t, cap)
//   VPL_RANGE_RANDOM  r_min + u (r_max - r_min), u = hash01(texel, seed)
//   VPL_RANGE_TABLE   vpl_table[j], precomputed (the exact baseline: Mitsuba on the same rays, in setup)
// The texel index is row-major with row 0 at the top, as the harness's RSM (its hash and rays match).
#include "vpl.glsl"
#if defined(VPL_RANGE_CDI)
#include "cdi_trace.glsl"
#endif
layout(local_size_x = 8, local_size_y = 8) in;
struct Vpl { vec4 pos_range; vec4 normal_area; vec4 flux; };
layout(std430, binding = B_VPLS) writeonly buffer Vpls { Vpl vpls[]; };
#if defined(VPL_RANGE_TABLE)
layout(std430, binding = B_VPL_TABLE) readonly buffer VplTable { float vpl_table[]; };
#endif
uniform sampler2D rsm_position;
uniform sampler2D rsm_normal;
uniform sampler2D rsm_flux;
uniform int rsm_size;           // R
uniform int vpl_step;
uniform int vpl_side;           // ceil(R / step)
uniform vec3 light_position;
uniform float cap;              // miss range, world units
uniform int range_max;          // 1: max, 0: mean
uniform float cos_a, sin_a;     // cone angle of the five rays around the primary one
uniform int primary_reflected;  // 1: reflected light direction, 0: normal
uniform uint seed;
uniform float r_min, r_max;     // world units

void main() {
    ivec2 jv = ivec2(gl_GlobalInvocationID.xy);
    if (jv.x >= vpl_side || jv.y >= vpl_side) return;
    uint j = uint(jv.y * vpl_side + jv.x);
    ivec2 tx = jv * vpl_step;
    vec4 p = texelFetch(rsm_position, tx, 0);
    vec4 flux = texelFetch(rsm_flux, tx, 0);
    if (p.w < 0.5 || max(flux.r, max(flux.g, flux.b)) <= 0.0) {
        vpls[j] = Vpl(vec4(0.0), vec4(0.0), vec4(0.0));
        return;
    }
    vec3 n = texelFetch(rsm_normal, tx, 0).xyz;
    uint texel = uint((rsm_size - 1 - tx.y) * rsm_size + tx.x);
    float range;
#if defined(VPL_RANGE_CDI)
    vec3 wi = normalize(p.xyz - light_position);
    vec3 pd = primary_reflected != 0 ? normalize(reflect(wi, n)) : n;
    vec3 t, b;
    tangent_frame(pd, t, b);
    float phi0 = VPL_TWO_PI * hash01(texel, seed);
    float acc = 0.0;
    for (uint k = 0u; k < 6u; ++k) {
        vec3 d = vpl_ray_dir(k, pd, t, b, phi0, cos_a, sin_a);
        float sigma;
        uint dir = cdi_nearest(d, sigma);
        float th = cdi_trace(dir, sigma, p.xyz, n);
        acc = range_accumulate(acc, th, cap, range_max);
    }
    range = range_finish(acc, range_max);
#elif defined(VPL_RANGE_RANDOM)
    range = r_min + hash01(texel, seed) * (r_max - r_min);
#else
    range = vpl_table[j];
#endif
    float s2 = float(vpl_step * vpl_step);
    vpls[j] = Vpl(vec4(p.xyz, range), vec4(n, flux.w * s2), vec4(flux.rgb * s2, 0.0));
}
