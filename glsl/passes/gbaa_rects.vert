// The window rectangles render.antialiasing = "gbaa"'s two draws cover (app/render/
// antialias.py GbaaPass: the opaque parts' screen rectangles, merged where they overlap):
// two triangles per rectangle from gl_VertexID alone, no vertex buffer. No silhouette lies
// outside them, and on a frame of a few objects they spare most of the image (the mark
// reads five surfaces per pixel it covers).
#ifndef GBAA_MAX_RECTS
#define GBAA_MAX_RECTS 16
#endif

uniform vec4 u_rects[GBAA_MAX_RECTS];   // NDC x0, y0, x1, y1

const vec2 CORNERS[6] = vec2[6](vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(1.0, 1.0),
                                vec2(0.0, 0.0), vec2(1.0, 1.0), vec2(0.0, 1.0));

void main() {
    vec4 rect = u_rects[gl_VertexID / 6];
    vec2 p = mix(rect.xy, rect.zw, CORNERS[gl_VertexID % 6]);
#ifndef RECT_DEPTH
#define RECT_DEPTH 0.0
#endif
    // RECT_DEPTH (NDC): the depth the resolve and the interior correction z-test against
    // the mark's (window 0.25 and 0.75: glsl/passes/gbaa.frag)
    gl_Position = vec4(p, RECT_DEPTH, 1.0);
}
