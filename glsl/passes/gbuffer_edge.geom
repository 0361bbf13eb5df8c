// G-buffer pass, geometry stage of render.antialiasing = "gbaa" (docs/antialiasing.md):
// passes every vertex on unchanged and adds what passes/gbuffer.frag needs to find the
// distance from a pixel centre to the surface's silhouette (Persson 2011, "Geometric
// Buffer Antialiasing", uses a geometry shader for the triangle's edges): the triangle's
// barycentric coordinates, interpolated linearly in window space (each is zero on the
// edge opposite its vertex); which of its edges can be a silhouette, those whose
// neighbouring triangle (GL_TRIANGLES_ADJACENCY, app/render/adjacency.py) faces the other
// way, is degenerate on screen or missing; and across each other edge, where the surface
// goes on into the neighbour, whether the neighbour may be the last triangle before the
// rim of a smooth mesh, a sliver on screen whose far edges are the silhouette (only the
// neighbours, not theirs, are known here): under RIM_HEIGHT pixels high, and turned
// further from the camera than this triangle (the cosine between its normal and the view
// ray no greater). Then the neighbour's far edges follow, as window-space lines: only a
// distance under a pixel is used, so a neighbour that is no sliver changes nothing.
// (Measured on the bench's icosphere: a neighbour under 2 pixels whose cosine,
// extrapolated past it, falls to half of this triangle's left 1.2x the silhouette error,
// the height alone more; no height limit as little as 6 pixels, for more fragment work.)
// passes/gbuffer.vert names its outputs vs_* here.
#include "geometry/edge.glsl"

layout(triangles_adjacency) in;
layout(triangle_strip, max_vertices = 3) out;

uniform vec2 u_image_size;   // pixels of the target

in vec3 vs_normal[];
in vec2 vs_uv[];
in vec4 vs_tangent[];
in float vs_view_depth[];
in vec3 vs_view_position[];
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
// per edge j (opposite vertex j): EDGE_SILHOUETTE, EDGE_RIM (the neighbour is the rim's
// last triangle) or 0 (the surface goes on)
flat out vec3 v_edge_kind;
// per edge j, the neighbour's far edges as lines n.x + c >= 0 inside it (window pixels)
flat out vec3 v_edge_beyond[6];

const float RIM_HEIGHT = 6.0;   // pixels

// The orientation of a, b, c on screen times the sign of their w's product: the
// determinant of their (x, y, w); its sign compares two triangles' facing.
float facing(vec4 a, vec4 b, vec4 c) {
    return determinant(mat3(a.xyw, b.xyw, c.xyw));
}

vec2 window(vec4 clip) {
    return (clip.xy / clip.w * 0.5 + 0.5) * u_image_size;
}

// The line through a and f, positive on the side of b.
vec3 line_toward(vec2 a, vec2 f, vec2 b) {
    vec2 n = vec2(f.y - a.y, a.x - f.x);
    float c = -dot(n, a);
    return dot(n, b) + c < 0.0 ? -vec3(n, c) : vec3(n, c);
}

// The height of f above the line through a and b (pixels).
float height(vec2 a, vec2 b, vec2 f) {
    vec2 e = b - a;
    return abs(e.x * (f.y - a.y) - e.y * (f.x - a.x)) / max(length(e), 1e-30);
}

// The cosine between triangle (a, b, c)'s normal (by its winding) and the direction
// from it to the camera, view space.
float view_cosine(vec3 a, vec3 b, vec3 c) {
    vec3 n = cross(b - a, c - a);
    vec3 centre = (a + b + c) / 3.0;
    return -dot(n, centre) / max(length(n) * length(centre), 1e-30);
}

void main() {
    // the triangle is gl_in[0, 2, 4]; gl_in[1, 3, 5] lie across its edges 0-2, 2-4, 4-0,
    // which are opposite its vertices 2, 0, 1 (where their barycentrics are zero)
    vec4 p[6];
    bool ahead = true;
    for (int i = 0; i < 6; ++i) {
        p[i] = gl_in[i].gl_Position;
        ahead = ahead && p[i].w > 0.0;
    }
    float own = facing(p[0], p[2], p[4]);
    // the neighbour across a -> b with the far vertex f, wound as the triangle: (a, f, b)
    vec3 across = vec3(facing(p[2], p[3], p[4]), facing(p[4], p[5], p[0]),
                       facing(p[0], p[1], p[2]));
    // a silhouette where the neighbour's facing is not the triangle's (or is none); where
    // a vertex lies behind the camera, every edge (the window positions are not known)
    bvec3 silhouette = ahead ? not(greaterThan(across * own, vec3(0.0))) : bvec3(true);
    vec3 kind = mix(vec3(0.0), vec3(EDGE_SILHOUETTE), silhouette);
    vec3 beyond[6];
    if (ahead) {
        vec2 s[6];
        for (int i = 0; i < 6; ++i) s[i] = window(p[i]);
        vec3 q[6];
        for (int i = 0; i < 6; ++i) q[i] = vs_view_position[i];
        float here = view_cosine(q[0], q[2], q[4]);
        vec3 there = vec3(view_cosine(q[2], q[3], q[4]), view_cosine(q[4], q[5], q[0]),
                          view_cosine(q[0], q[1], q[2]));
        vec3 high = vec3(height(s[2], s[4], s[3]), height(s[4], s[0], s[5]),
                         height(s[0], s[2], s[1]));
        // under RIM_HEIGHT pixels high and turned further away (signs as this triangle's)
        bvec3 rim = bvec3(vec3(lessThan(high, vec3(RIM_HEIGHT)))
                          * vec3(lessThanEqual(there * sign(here), vec3(abs(here)))));
        kind = mix(kind, vec3(EDGE_RIM), bvec3(rim.x && !silhouette.x, rim.y && !silhouette.y,
                                               rim.z && !silhouette.z));
        beyond[0] = line_toward(s[2], s[3], s[4]);   // edge 2-4 (opposite vertex 0)
        beyond[1] = line_toward(s[3], s[4], s[2]);
        beyond[2] = line_toward(s[4], s[5], s[0]);   // edge 4-0 (opposite vertex 1)
        beyond[3] = line_toward(s[5], s[0], s[4]);
        beyond[4] = line_toward(s[0], s[1], s[2]);   // edge 0-2 (opposite vertex 2)
        beyond[5] = line_toward(s[1], s[2], s[0]);
    } else {
        for (int i = 0; i < 6; ++i) beyond[i] = vec3(0.0);
    }
    for (int k = 0; k < 3; ++k) {
        int i = 2 * k;
        gl_Position = p[i];
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
        v_edge_barycentric = vec3(k == 0, k == 1, k == 2);
        v_edge_kind = kind;
        for (int j = 0; j < 6; ++j) v_edge_beyond[j] = beyond[j];
        EmitVertex();
    }
    EndPrimitive();
}
