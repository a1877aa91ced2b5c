// Fragments per pixel of the camera view (additive blending of 1 per fragment, both faces, no depth test):
// the depth complexity counters of dual-depth-peeling, rendered outside the timed frame.
#if defined(VERTEX_SHADER)
uniform mat4 clip;
in vec3 in_position;
void main() { gl_Position = clip * vec4(in_position, 1.0); }
#elif defined(FRAGMENT_SHADER)
layout(location = 0) out float out_count;
void main() { out_count = 1.0; }
#endif
