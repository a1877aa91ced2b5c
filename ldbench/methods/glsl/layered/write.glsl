// The prologue of every pass that stores fragments into a layered structure (layered/build.glsl,
// layered/build_one_pass.glsl, layered/splat_raster.glsl; include it first, before any declaration): the
// extensions of the subgroup-aggregated allocation (LL_AGGREGATE) and the writable structure interfaces.
#if defined(LL_AGGREGATE)
#extension GL_ARB_shader_ballot : require
#extension GL_ARB_gpu_shader_int64 : require
#endif
#define LL_WRITABLE 1
#define LA_WRITABLE 1
#include "layered/layered.glsl"
