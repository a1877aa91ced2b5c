// The `rays` effect's batch on the GPU (ldbench/core/effects/rays.py RayBatch.upload): per ray
// vec4(origin, tmax), vec4(direction, 0), vec4(normal at the origin, 0); and the tracer's answer:
// the hit distance per ray (uintBitsToFloat(0x7f800000) = +inf for a miss).
#ifndef LDBENCH_RAYS_GLSL
#define LDBENCH_RAYS_GLSL
struct Ray { vec4 o_tmax; vec4 d; vec4 n; };
layout(std430, binding = B_RAYS) readonly buffer RayBatch { Ray rays[]; };
layout(std430, binding = B_HITS) writeonly buffer RayHits { float ray_t[]; };
const float RAY_MISS = uintBitsToFloat(0x7f800000u);
#endif
