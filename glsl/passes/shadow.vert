// Shadow pass, vertex stage (app/render/shadows.py): object -> world -> the light's clip
// space. Depth only: no fragment outputs (passes/shadow.frag is empty).
in vec3 in_position;

uniform mat4 u_model;
uniform mat4 u_light_matrix;   // world -> the shadow map's clip space

void main() {
    gl_Position = u_light_matrix * (u_model * vec4(in_position, 1.0));
}
