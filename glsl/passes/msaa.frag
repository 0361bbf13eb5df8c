// The edge mark of render.antialiasing = "msaa" (app/render/msaa.py, MsaaPass): copies
// the frame's HDR image (shaded once per pixel, at its centre) and writes window depth 0
// where the pixel's multisampled G-buffer samples hold different surfaces, 1 elsewhere.
// A sample differs from sample 0 where one sees no surface and the other one, their
// material ids differ, their view depths differ by more than u_depth_tolerance of the
// nearer, or their octahedral normals by more than u_normal_tolerance in a coordinate;
// the pixel's centre (RT2 of the one-sample G-buffer) counts as a sample too (id and
// depth). The lighting pass (passes/lighting.frag under GBUFFER_SAMPLES) is then drawn on
// the far plane with the test ">" and shades the marked pixels once per sample. After the
// deferred MSAA of A. Lauritzen, "Deferred Rendering for Current and Future Rendering
// Pipelines" (SIGGRAPH 2010 course), written for this project.
uniform sampler2D u_hdr;           // linear HDR RGBA, shaded at the pixel centres
uniform sampler2D u_depth;         // the frame's RT2: view depth (0: background), material id
uniform sampler2DMS u_samples;     // the multisampled RT2
uniform sampler2DMS u_normals;     // the multisampled RT1 (octahedral normal in .xy)
uniform float u_depth_tolerance;
uniform float u_normal_tolerance;

out vec4 frag_color;

bool covered(float z) {
    return !isnan(z) && !isinf(z) && z > 0.0;
}

bool same_surface(vec2 a, vec2 b) {
    if (!covered(a.x) || !covered(b.x)) return !covered(a.x) && !covered(b.x);
    return a.y == b.y && abs(a.x - b.x) <= u_depth_tolerance * min(a.x, b.x);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 g0 = texelFetch(u_samples, px, 0).xy;
    vec2 n0 = texelFetch(u_normals, px, 0).xy;
    bool edge = !same_surface(g0, texelFetch(u_depth, px, 0).xy);
    for (int s = 1; s < SAMPLES; ++s) {
        vec2 gs = texelFetch(u_samples, px, s).xy;
        vec2 ns = texelFetch(u_normals, px, s).xy;
        edge = edge || !same_surface(g0, gs)
               || (covered(g0.x) && any(greaterThan(abs(ns - n0), vec2(u_normal_tolerance))));
    }
    frag_color = texelFetch(u_hdr, px, 0);
    gl_FragDepth = edge ? 0.0 : 1.0;
}
