// Whether dFdx and dFdy are fine here (app/render/antialias.py fine_derivatives): GLSL
// 3.30 leaves it to the implementation whether a 2x2 quad's lanes share one difference
// (coarse) or each row and column has its own (fine); passes/gbaa.frag's QUAD_NEIGHBOURS
// takes a lane's neighbour inside its quad from them, so needs fine ones. Of f = x y (x, y
// the pixel's integer position), a fine dFdx is the row's y and a fine dFdy the column's x.
out vec4 frag_color;

void main() {
    vec2 p = floor(gl_FragCoord.xy);
    float f = p.x * p.y;
    frag_color = vec4(dFdx(f), dFdy(f), p);
}
