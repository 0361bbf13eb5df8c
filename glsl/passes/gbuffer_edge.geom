// G-buffer pass, geometry stage of render.antialiasing = "gbaa" (docs/antialiasing.md):
// passes every vertex on unchanged and adds the triangle's barycentric coordinates,
// interpolated linearly in window space, from which passes/gbuffer.frag finds the
// distance to the triangle's edges (Persson 2011, "Geometric Buffer Antialiasing", uses a
// geometry shader for the same purpose). passes/gbuffer.vert names its outputs vs_* here.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

in vec3 vs_normal[];
in vec2 vs_uv[];
in vec4 vs_tangent[];
in float vs_view_depth[];
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
out float v_view_depth;
#if VERTEX_COLOR
in vec4 vs_color[];
out vec4 v_color;
#endif
#if VERTEX_UV1
in vec2 vs_uv1[];
out vec2 v_uv1;
#endif
noperspective out vec3 v_edge_barycentric;

void main() {
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        v_normal = vs_normal[i];
        v_uv = vs_uv[i];
        v_tangent = vs_tangent[i];
        v_view_depth = vs_view_depth[i];
#if VERTEX_COLOR
        v_color = vs_color[i];
#endif
#if VERTEX_UV1
        v_uv1 = vs_uv1[i];
#endif
        v_edge_barycentric = vec3(i == 0, i == 1, i == 2);
        EmitVertex();
    }
    EndPrimitive();
}
