// Supersampling's resolve: each output pixel is the box average of its FACTOR x FACTOR
// block of linear HDR radiance (the pixel integral; tone mapping comes after).
uniform sampler2D u_hdr;
uniform int u_factor;

out vec4 frag_color;

void main() {
    ivec2 origin = ivec2(gl_FragCoord.xy) * u_factor;
    vec3 sum = vec3(0.0);
    for (int y = 0; y < u_factor; ++y) {
        for (int x = 0; x < u_factor; ++x) {
            sum += texelFetch(u_hdr, origin + ivec2(x, y), 0).rgb;
        }
    }
    frag_color = vec4(sum / float(u_factor * u_factor), 1.0);
}
