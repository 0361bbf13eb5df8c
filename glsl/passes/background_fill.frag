// Background fill: one colour on every pixel no surface was drawn into. Drawn with
// passes/fullscreen.vert's FAR_PLANE triangle against the G-buffer's z-buffer with the
// test "<=", which passes only where z is still the cleared 1. The lighting pass leaves
// those pixels of its HDR image unwritten where nothing reads them before the image is
// read back (app/render/renderer.py, Renderer.run_lighting); this writes the value its
// clear would have written, the same float32 colour.
uniform vec4 u_fill;

out vec4 frag_color;

void main() {
    frag_color = u_fill;
}
