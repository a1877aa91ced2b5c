// The vertex stage of both peeling methods (depth_peeling/peel.glsl, dual_depth_peeling/peel.glsl; include
// it inside their VERTEX_SHADER section): the camera's clip position, the linear view depth
// dot(depth_row, p) and the material index (uniforms set by ldbench/methods/oit.py OITMethod.camera_program).
uniform mat4 clip;
uniform vec4 depth_row;
in vec3 in_position;
in float in_material;
out float v_depth;
flat out uint v_material;
void main() {
    vec4 p = vec4(in_position, 1.0);
    gl_Position = clip * p;
    v_depth = dot(depth_row, p);
    v_material = uint(in_material + 0.5);
}
