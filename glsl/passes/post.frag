// Post pass: exposure, tone mapping, sRGB encoding of the HDR image.
// With STRAIGHT_ALPHA (render.background = "transparent") the HDR image is RGBA
// premultiplied by coverage (alpha 0 where no surface is): the colour is divided by its
// alpha before exposure and the tone map, which act on the surface's own radiance, so an
// edge pixel is not darkened, and the display image holds straight alpha (PNG's).
#include "post/tonemap.glsl"

#ifndef STRAIGHT_ALPHA
#define STRAIGHT_ALPHA 0
#endif

uniform sampler2D u_hdr;
uniform float u_exposure;   // linear scale, 2^EV

out vec4 frag_color;

void main() {
#if STRAIGHT_ALPHA
    vec4 texel = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0);
    float a = clamp(texel.a, 0.0, 1.0);
    vec3 c = (a > 0.0 ? texel.rgb / a : vec3(0.0)) * u_exposure;
    frag_color = vec4(srgb_encode(tonemap_selected(c)), a);
#else
    vec3 c = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure;
    frag_color = vec4(srgb_encode(tonemap_selected(c)), 1.0);
#endif
}
