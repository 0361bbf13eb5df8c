// Supersampling's resolve: each output pixel is the box average of its FACTOR x FACTOR
// block of linear HDR radiance (the pixel integral; tone mapping comes after). All four
// channels: the HDR image is premultiplied by coverage (alpha), so the mean of the block's
// alpha is the pixel's antialiased coverage (docs/architecture.md, "Alpha").
uniform sampler2D u_hdr;
uniform int u_factor;

out vec4 frag_color;

void main() {
    ivec2 origin = ivec2(gl_FragCoord.xy) * u_factor;
    vec4 sum = vec4(0.0);
    for (int y = 0; y < u_factor; ++y) {
        for (int x = 0; x < u_factor; ++x) {
            sum += texelFetch(u_hdr, origin + ivec2(x, y), 0);
        }
    }
    frag_color = sum / float(u_factor * u_factor);
}
