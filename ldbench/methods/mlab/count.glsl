// Per-pixel bookkeeping of the k-buffer (one invocation per pixel):
//   CLEAR: empty every pixel's layers and release its lock (the first stage of a frame);
//   else:  layers in use per pixel into an R32F image (the depth-complexity counters, read after timing).
layout(local_size_x = 64) in;
layout(std430, binding = B_MLAB_COUNTS) buffer MlabCounts { uint count[]; };
layout(std430, binding = B_MLAB_LOCKS) buffer MlabLocks { uint lock_word[]; };
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_image;
uniform ivec2 size;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(size.x * size.y)) return;
#ifdef CLEAR
    count[i] = 0u;
    lock_word[i] = 0u;
#else
    imageStore(out_image, ivec2(int(i) % size.x, int(i) / size.x), vec4(float(count[i])));
#endif
}
