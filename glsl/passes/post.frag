// Post pass: exposure, tone mapping, sRGB encoding of the HDR image.
#include "post/tonemap.glsl"

uniform sampler2D u_hdr;
uniform float u_exposure;   // linear scale, 2^EV

out vec4 frag_color;

void main() {
    vec3 c = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure;
    frag_color = vec4(srgb_encode(tonemap_selected(c)), 1.0);
}
