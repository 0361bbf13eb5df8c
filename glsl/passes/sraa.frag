// Subpixel reconstruction antialiasing (app/render/antialias.py, SraaPass): after
// Chajdas, McGuire & Luebke, "Subpixel Reconstruction Antialiasing for Deferred
// Shading" (I3D 2011); written for this project. The frame is shaded once per pixel at
// its centre (u_hdr); a geometry pass rasterised SAMPLES samples per pixel (u_samples:
// view depth and material id, as RT2). Each sample takes the shaded colour of the pixel
// among its own and its eight neighbours whose centre saw the same surface (the same
// material id, a depth within u_depth_tolerance of the sample's; or the background for
// a background sample), the nearest in depth; the pixel's colour is the mean of its
// centre and its samples. Linear HDR, alpha with the colour: premultiplied RGBA stays
// premultiplied, so a transparent background's coverage becomes fractional alpha.
//
// Two draws, as the FXAA pass does (llvmpipe runs every branch of a fragment shader for
// its whole block of pixels; the z-test skips blocks): SRAA_MARK copies every pixel's
// colour and writes window depth 0 where a sample saw another surface than the centre
// (an edge), 1 elsewhere; the reconstruction is drawn on the far plane with the test ">"
// and so runs at the edge pixels alone.
uniform sampler2D u_hdr;        // linear HDR RGBA of the pixel-centre frame
uniform sampler2D u_depth;      // the frame's RT2: view depth (0: background), material id
uniform sampler2DMS u_samples;  // the multisampled RT2
uniform float u_depth_tolerance;

out vec4 frag_color;

bool same_surface(vec2 centre, vec2 s) {
    if (centre.x == 0.0 || s.x == 0.0) return centre.x == 0.0 && s.x == 0.0;
    return centre.y == s.y && abs(centre.x - s.x) <= u_depth_tolerance * s.x;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 own = texelFetch(u_hdr, px, 0);
    vec2 g0 = texelFetch(u_depth, px, 0).xy;
#ifdef SRAA_MARK
    bool edge = false;
    for (int s = 0; s < SAMPLES; ++s) {
        edge = edge || !same_surface(g0, texelFetch(u_samples, px, s).xy);
    }
    frag_color = own;
    gl_FragDepth = edge ? 0.0 : 1.0;
#else
    ivec2 last = textureSize(u_depth, 0) - 1;
    vec4 sum = own;   // the centre's sample
    for (int s = 0; s < SAMPLES; ++s) {
        vec2 gs = texelFetch(u_samples, px, s).xy;
        vec4 colour = own;
        if (!same_surface(g0, gs)) {
            float best = 1e30;
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                    ivec2 q = clamp(px + ivec2(dx, dy), ivec2(0), last);
                    vec2 gq = texelFetch(u_depth, q, 0).xy;
                    if (!same_surface(gq, gs)) continue;
                    float distance = abs(gq.x - gs.x);
                    if (distance < best) {
                        best = distance;
                        colour = texelFetch(u_hdr, q, 0);
                    }
                }
            }
        }
        sum += colour;
    }
    frag_color = sum / float(SAMPLES + 1);
#endif
}
