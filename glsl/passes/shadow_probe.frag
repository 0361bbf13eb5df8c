// The hardware PCF probe (app/render/shadows.py probe_hardware_pcf): pixel i of a row
// reads the probe's depth texture (compare mode <=, LINEAR) through sampler2DShadow at
// u_probe[i] (xy its texture coordinates, z the reference depth) and writes the result,
// which the probe compares with the weighted 2 x 2 average the lookup relies on.
uniform sampler2DShadow u_depth;
uniform vec3 u_probe[PROBE_POINTS];

out vec4 frag_color;

void main() {
    frag_color = vec4(texture(u_depth, u_probe[int(gl_FragCoord.x)]), 0.0, 0.0, 1.0);
}
