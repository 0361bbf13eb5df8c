// The blocks render.antialiasing = "fxaa"'s filter draws (app/render/antialias.py
// FxaaPass): one point of FXAA_BLOCK pixels per block of the mark's image (one texel per
// block, 1 where the block holds an edge), from gl_VertexID alone, no vertex buffer; an
// unmarked block's point lies outside the clip volume. The viewport is the blocks' whole
// grid (FXAA_BLOCK x the mark's size, past an image whose size is no multiple of it), so
// that a point's centre, (X + 0.5) * FXAA_BLOCK, never lies outside it.
uniform sampler2D u_mark;

void main() {
    ivec2 grid = textureSize(u_mark, 0);
    ivec2 block = ivec2(gl_VertexID % grid.x, gl_VertexID / grid.x);
    vec2 centre = (vec2(block) + 0.5) / vec2(grid) * 2.0 - 1.0;
    bool marked = texelFetch(u_mark, block, 0).r > 0.0;
    gl_Position = marked ? vec4(centre, 0.0, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
    gl_PointSize = float(FXAA_BLOCK);
}
