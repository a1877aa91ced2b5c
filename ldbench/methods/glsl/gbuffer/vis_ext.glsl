// The extensions of the compute G-buffer's one-pass visibility buffer (gbuffer/vis.glsl, GB_VIS64): included
// first by every program that includes gbuffer/vis.glsl, since #extension must precede any other token.
#if defined(GB_VIS64)
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_NV_shader_atomic_int64 : require
#endif
