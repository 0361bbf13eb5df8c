// The blocks render.antialiasing = "fxaa"'s filter draws (app/render/antialias.py
// FxaaPass): one point of FXAA_BLOCK pixels per marked block, a_block its index in the
// grid of blocks (row by row, u_grid blocks wide and high), the list the mark's image
// gives. The viewport is the whole grid (FXAA_BLOCK x u_grid pixels, past an image whose
// size is no multiple of it), so that a point's centre, (X + 0.5) * FXAA_BLOCK, never
// lies outside it (a point whose centre is outside is clipped whole).
uniform ivec2 u_grid;

in int a_block;

void main() {
    ivec2 block = ivec2(a_block % u_grid.x, a_block / u_grid.x);
    gl_Position = vec4((vec2(block) + 0.5) / vec2(u_grid) * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = float(FXAA_BLOCK);
}
