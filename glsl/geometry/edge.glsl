// Distances to a surface's edge for render.antialiasing = "gbaa" (docs/antialiasing.md):
// what passes/gbuffer.frag writes into the G-buffer's edge target and
// passes/gbuffer_edge.geom hands it for a mesh's triangles.
#ifndef PBS_EDGE_GLSL
#define PBS_EDGE_GLSL

// No edge nearer than this many pixels in a direction (the target holds float16).
const float EDGE_FAR = 16.0;
// A triangle edge's kind (passes/gbuffer_edge.geom): 0 the surface goes on past it;
// EDGE_SILHOUETTE it can be a silhouette; EDGE_RIM the neighbour past it is the last
// triangle before a smooth mesh's rim, whose far edges bound the surface.
const float EDGE_SILHOUETTE = 1.0;
const float EDGE_RIM = 2.0;

// The distance in pixels from the pixel centre along +x, -x, +y, -y to where f, a
// quantity linear in window space across the pixel with gradient grad, positive inside
// the surface and zero on its edge, reaches zero (Persson 2011, "Geometric Buffer
// Antialiasing": the 1D distance along an axis gives a half-plane's box-filtered
// coverage); EDGE_FAR where f does not fall that way.
vec4 edge_distances(float f, vec2 grad) {
    vec4 slope = vec4(-grad.x, grad.x, -grad.y, grad.y);   // f's fall per pixel each way
    vec4 d = vec4(f) / max(slope, vec4(1e-30));
    return mix(vec4(EDGE_FAR), clamp(d, 0.0, EDGE_FAR), greaterThan(slope, vec4(0.0)));
}

#endif
