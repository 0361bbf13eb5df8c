// G-buffer pass, vertex stage: object -> world -> clip. The bench's forward pass
// (app/bench/forward.py) draws with it too, so both passes rasterise the same pixels
// and interpolate the same view depth.
#if GBUFFER_EDGE_GEOMETRY
// A geometry stage follows (passes/gbuffer_edge.geom): it reads these outputs under the
// vs_ names and passes them on to the fragment stage under their own.
#define v_normal vs_normal
#define v_uv vs_uv
#define v_tangent vs_tangent
#define v_view_depth vs_view_depth
#define v_color vs_color
#define v_uv1 vs_uv1
out vec3 vs_view_position;   // the geometry stage's facing of each triangle
#endif
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;     // xyz along +u, w = handedness

#if VERTEX_COLOR
in vec4 in_color;       // glTF COLOR_0, linear RGBA (a second vertex buffer)
out vec4 v_color;
#endif
#if VERTEX_UV1
in vec2 in_uv1;         // glTF TEXCOORD_1 (the second vertex buffer)
out vec2 v_uv1;
#endif

uniform mat4 u_model;
uniform mat3 u_normal_matrix;   // inverse-transpose of u_model's upper 3x3
uniform mat4 u_view;
uniform mat4 u_proj;
uniform float u_tangent_sign;  // -1 where u_model mirrors (det < 0): it flips (t, b, n)'s handedness

out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;   // xyz along +u, w = handedness
out float v_view_depth;   // metres along the view axis

void main() {
    v_normal = u_normal_matrix * in_normal;
    v_uv = in_uv;
#if VERTEX_COLOR
    v_color = in_color;
#endif
#if VERTEX_UV1
    v_uv1 = in_uv1;
#endif
    v_tangent = vec4(mat3(u_model) * in_tangent.xyz, in_tangent.w * u_tangent_sign);   // tangents transform with the surface
    vec4 view = u_view * (u_model * vec4(in_position, 1.0));
    v_view_depth = -view.z;
#if GBUFFER_EDGE_GEOMETRY
    vs_view_position = view.xyz;
#endif
    gl_Position = u_proj * view;
}
