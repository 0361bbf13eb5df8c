// One triangle that covers the viewport; no vertex buffer needed.
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
#ifdef FAR_PLANE
    // On the far plane (window depth exactly 1): the lighting pass draws it with the
    // G-buffer's z-buffer attached and the test ">", so that only pixels a surface was
    // drawn into (z < 1) run the fragment shader (app/render/lighting.py).
    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
#else
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
#endif
}
