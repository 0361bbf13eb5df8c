// Geometric edge antialiasing (render.antialiasing = "gbaa", docs/antialiasing.md), after
// E. Persson, "Geometric Buffer Antialiasing" (SIGGRAPH 2011 talk) and the distance-to-edge
// idea of Malan, "Edge Anti-aliasing by Post-Processing" (GPU Pro, 2010); written for this
// project. The G-buffer pass wrote, per pixel, the distance from its centre to its
// surface's edge along +x, -x, +y, -y (g_edge, passes/gbuffer.frag). For a half-plane
// edge, the pixel's box-filtered coverage by its surface is 0.5 + d, d the distance along
// the axis nearest the edge's normal (the smallest of the four), while d < 0.5; a
// neighbour whose edge lies d' in (0.5, 1) from its centre toward this pixel covers this
// pixel by d' - 0.5. Only where the two pixels hold different surfaces (the background,
// another material, or a depth jump) is an edge a silhouette: a triangle's edge inside a
// mesh blends nothing. The occluder's edge decides: the nearer surface's pixel blends with
// the one behind, and a pixel behind takes the nearer neighbour's overlap. The mix is of
// linear HDR radiance (RGBA: premultiplied coverage stays premultiplied), then exposed,
// tone mapped and encoded as passes/post.frag does.
// Two draws (app/render/antialias.py GbaaPass): GBAA_MARK writes window depth 0 where a
// pixel differs in surface from a 4-neighbour, 1 elsewhere; the resolve runs on the far
// plane with the test ">", so only blocks with a silhouette pay for it (llvmpipe shades
// every branch for a whole block: one draw that discards the other pixels took 10 ms at
// 640x360, the two 3 ms), and writes the display image there.
#include "post/tonemap.glsl"

#ifndef STRAIGHT_ALPHA
#define STRAIGHT_ALPHA 0
#endif
#ifndef GBAA_AXIS_TIE
#define GBAA_AXIS_TIE 1.1   // a neighbour's edge counts along an axis within 10 % of its nearest
#endif
#ifndef GBAA_DEPTH_TOLERANCE
#define GBAA_DEPTH_TOLERANCE 0.1   // view depths further apart than this fraction differ
#endif

uniform sampler2D u_depth;   // RT2: view depth (0: background), material id
uniform sampler2D u_edge;    // RT7: distances to the surface's edge along +x, -x, +y, -y
uniform sampler2D u_hdr;     // linear HDR RGBA (premultiplied where transparent)
uniform float u_exposure;    // linear scale, 2^EV
// 1: the background pixels' radiance is u_background, not u_hdr's (where the lighting
// pass wrote the display image and the surfaces' radiance alone: Renderer.run_lighting)
uniform float u_uniform_background;
uniform vec4 u_background;

out vec4 frag_color;

const ivec2 STEPS[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));

ivec2 g_last;

vec2 surface_at(ivec2 px) {
    return texelFetch(u_depth, clamp(px, ivec2(0), g_last), 0).xy;
}

// Whether surface a (RT2 texel) lies in front of surface b and is another one: a surface
// before the background, or another material or a depth jump, the nearer.
bool in_front(vec2 a, vec2 b) {
    if (!(a.x > 0.0)) return false;
    if (!(b.x > 0.0)) return true;
    bool other = a.y != b.y || abs(a.x - b.x) > GBAA_DEPTH_TOLERANCE * min(a.x, b.x);
    return other && a.x < b.x;
}

// The HDR radiance of pixel px whose RT2 texel is surface.
vec4 radiance(ivec2 px, vec2 surface) {
    if (u_uniform_background > 0.0 && !(surface.x > 0.0)) return u_background;
    return texelFetch(u_hdr, clamp(px, ivec2(0), g_last), 0);
}

// The radiance of surface pixel px at `shift` pixels from its centre toward `step` (the
// centroid of the part of a pixel its surface covers, not the centre it was shaded at):
// linear through px's radiance and its neighbour's on the other side (px - step) where
// that one holds the same surface, else px's own. A rim's shading falls steeply toward
// the silhouette (n.l, n.v to 0): with the centre's shading alone a rim lit from the
// viewer drew a line darker inside and brighter outside than the area mean
// (docs/accuracy.md, "Every pixel"). That neighbour need not be marked: the HDR image
// holds every surface pixel's radiance.
vec4 covered_radiance(ivec2 px, vec2 surface, ivec2 step, float shift) {
    vec4 c = radiance(px, surface);
    vec2 beyond = surface_at(px - step);
    bool same = beyond.x > 0.0 && beyond.y == surface.y &&
                abs(beyond.x - surface.x) <= GBAA_DEPTH_TOLERANCE * min(beyond.x, surface.x);
    if (!same) return c;
    vec4 b = radiance(px - step, beyond);
    // A pixel's own part is moved inward only where the shading falls toward the rim
    // (brighter inside): where it rises (sheen, a grazing highlight) the line through two
    // centres undershoots the peak at the silhouette, and the centre's own measured closer.
    if (shift < 0.0 && dot(c.rgb, vec3(1.0)) >= dot(b.rgb, vec3(1.0))) return c;
    // within a factor of 2 of px's own: a highlight or a texture beyond is no slope
    return clamp(c + shift * (c - b), 0.5 * c, 2.0 * c);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    g_last = textureSize(u_depth, 0) - 1;
    vec2 centre = surface_at(px);
    vec2 around[4];
    for (int k = 0; k < 4; ++k) around[k] = surface_at(px + STEPS[k]);
    // another surface in a 4-neighbour (in_front either way), in arithmetic
    bvec4 other = bvec4(false);
    for (int k = 0; k < 4; ++k) {
        vec2 q = around[k];
        other[k] = (q.x > 0.0) != (centre.x > 0.0) || (centre.x > 0.0 &&
                   (q.y != centre.y || abs(q.x - centre.x) > GBAA_DEPTH_TOLERANCE * min(q.x, centre.x)));
    }
#ifdef GBAA_MARK
    frag_color = vec4(0.0);
    gl_FragDepth = any(other) ? 0.0 : 1.0;
#else
    // this pixel's own edge: the nearest toward a neighbour behind it
    vec4 own = texelFetch(u_edge, px, 0);
    float weight[4] = float[4](0.0, 0.0, 0.0, 0.0);
    float nearest = 0.5;
    int toward = -1;
    for (int k = 0; k < 4; ++k) {
        if (in_front(centre, around[k]) && own[k] < nearest) {
            nearest = own[k];
            toward = k;
        }
    }
    if (toward >= 0) weight[toward] = 0.5 - nearest;
    // the neighbours in front whose edge reaches into this pixel, along their major axis
    float front[4] = float[4](0.0, 0.0, 0.0, 0.0);
    for (int k = 0; k < 4; ++k) {
        if (!in_front(around[k], centre)) continue;
        vec4 theirs = texelFetch(u_edge, clamp(px + STEPS[k], ivec2(0), g_last), 0);
        int back = k ^ 1;   // from the neighbour toward this pixel
        float d = theirs[back];
        float across = k < 2 ? min(theirs.z, theirs.w) : min(theirs.x, theirs.y);
        if (d > 0.5 && d < 1.0 && d <= GBAA_AXIS_TIE * across) front[k] = d - 0.5;
    }
    // Near 45 degrees the two axes tie: the neighbours across x and across y see the same
    // corner of this pixel (each alone measures it); keep the axis that sees more of it.
    float fx = front[0] + front[1], fy = front[2] + front[3];
    if (fx > 0.0 && fy > 0.0) {
        if (fx >= fy) { front[2] = 0.0; front[3] = 0.0; } else { front[0] = 0.0; front[1] = 0.0; }
    }
    for (int k = 0; k < 4; ++k) weight[k] += front[k];
    float total = weight[0] + weight[1] + weight[2] + weight[3];
    float scale = total > 1.0 ? 1.0 / total : 1.0;
    // own part: covered from -0.5 to `nearest` toward the edge, centroid (0.5 - nearest)/2
    // away from it; a neighbour's sliver: from 0.5 to d of its centre, centroid (0.5 + d)/2
    vec4 c = (toward >= 0 ? covered_radiance(px, centre, STEPS[toward], -0.5 * weight[toward])
                          : radiance(px, centre)) * (1.0 - min(total, 1.0));
    for (int k = 0; k < 4; ++k) {
        if (weight[k] > 0.0 && k != toward) {
            float shift = 0.5 * (weight[k] + 1.0);   // (0.5 + d)/2, d = weight + 0.5
            c += weight[k] * scale * covered_radiance(px + STEPS[k], around[k], -STEPS[k], shift);
        } else if (weight[k] > 0.0) {
            c += weight[k] * scale * radiance(px + STEPS[k], around[k]);
        }
    }
#if STRAIGHT_ALPHA
    float a = clamp(c.a, 0.0, 1.0);
    vec3 rgb = (a > 0.0 ? c.rgb / a : vec3(0.0)) * u_exposure;
    frag_color = vec4(srgb_encode(tonemap_selected(rgb)), a);
#else
    frag_color = vec4(srgb_encode(tonemap_selected(c.rgb * u_exposure)), 1.0);
#endif
#endif
}
