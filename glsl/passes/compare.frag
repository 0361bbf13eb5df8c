// Comparison composite: one scene rendered with two settings of one key (side A, side B),
// shown split at a divider or as the magnified difference of their radiance.
// Python side: app/render/compare.py (ComparePass); docs/compare.md.
//
//   split (default): column x takes side A's display image where x < u_divider, side B's
//     from there on, except the columns u_line.x <= x < u_line.y, which are the divider
//     line in u_line_color. Each side's pixels are copied untouched: 8-bit in, 8-bit out,
//     so each half is bit for bit the side's own render.
//   COMPARE_DIFFERENCE: |A - B| of the linear HDR radiance (each side exposed by its own
//     2^EV, RTR4 sec. 9.2), times u_gain, then the post pass's tone map and sRGB encoding
//     (post/tonemap.glsl, TONEMAP: side A's render.tonemap). Equal radiance gives 0, and
//     every tone map and the sRGB curve send 0 to 0: black.
#include "post/tonemap.glsl"

#ifdef COMPARE_DIFFERENCE
uniform sampler2D u_hdr_a;
uniform sampler2D u_hdr_b;
uniform vec2 u_exposure;    // 2^EV of side A, side B
uniform float u_gain;       // magnification of the difference
#else
uniform sampler2D u_ldr_a;
uniform sampler2D u_ldr_b;
uniform int u_divider;      // first column of side B
uniform ivec2 u_line;       // the divider line's columns: [x, y)
uniform vec3 u_line_color;  // 8-bit values / 255, so they are written back exactly
#endif

out vec4 frag_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#ifdef COMPARE_DIFFERENCE
    vec3 a = texelFetch(u_hdr_a, p, 0).rgb * u_exposure.x;
    vec3 b = texelFetch(u_hdr_b, p, 0).rgb * u_exposure.y;
    vec3 d = abs(a - b) * u_gain;
    frag_color = vec4(srgb_encode(tonemap_selected(d)), 1.0);
#else
    if (p.x >= u_line.x && p.x < u_line.y) {
        frag_color = vec4(u_line_color, 1.0);
    } else if (p.x < u_divider) {
        frag_color = texelFetch(u_ldr_a, p, 0);
    } else {
        frag_color = texelFetch(u_ldr_b, p, 0);
    }
#endif
}
