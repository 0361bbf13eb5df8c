// The HDR image's background: the uniform background radiance (alpha: 1, or 0 for a
// transparent background), drawn by the lighting pass (app/render/lighting.py,
// LightingPass.run) as the far-plane triangle with the test "<=" against the G-buffer's
// z-buffer, so that it writes exactly the pixels the G-buffer pass left at the cleared
// far value: the ones the lighting draw's ">" test skips. Cheaper than clearing the whole
// RGBA32F target first (docs/performance.md, "Fixed costs").
uniform vec4 u_background;

out vec4 frag_color;

void main() {
    frag_color = u_background;
}
