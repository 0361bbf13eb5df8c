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
// pixel differs in surface from a 4-neighbour, else 1 on a surface and 0.5 on the
// background; the resolve runs at depth 0.25 with the test ">", so only blocks with a
// silhouette pay for it (llvmpipe shades every branch for a whole block: one draw that
// discards the other pixels took 10 ms at 640x360, the two 3 ms), and writes the display
// image there. With render.gbaa_interior a third draw, GBAA_CORRECT, runs between them at depth
// 0.75 with the test "<": at the interior surface pixels alone (all four neighbours its
// own surface), whose display value it writes from the HDR image alone.
// With QUAD_NEIGHBOURS (where the derivatives are fine: app/render/antialias.py
// quad_neighbour_defines) each lane fetches its own texel and its two neighbours outside
// its 2x2 quad, and takes the one inside the quad from the derivative: three fetches of
// each target instead of five (a fetch is most of these draws' cost on llvmpipe). With
// FINE_DERIVATIVES (a program of GLSL 4.00: app/gl/shaders.py) those are dFdxFine and
// dFdyFine, fine by definition, else dFdx and dFdy, which a probe draw found fine here.
#include "post/tonemap.glsl"

#ifndef STRAIGHT_ALPHA
#define STRAIGHT_ALPHA 0
#endif
#ifndef QUAD_NEIGHBOURS
#define QUAD_NEIGHBOURS 0
#endif
#ifndef FINE_DERIVATIVES
#define FINE_DERIVATIVES 0
#endif
#ifndef GBAA_AXIS_TIE
#define GBAA_AXIS_TIE 1.1   // a neighbour's edge counts along an axis within 10 % of its nearest
#endif
#ifndef GBAA_DEPTH_TOLERANCE
#define GBAA_DEPTH_TOLERANCE 0.1   // view depths further apart than this fraction differ
#endif
#ifndef GBAA_EXACT
#define GBAA_EXACT 0
#endif
#ifndef GBAA_SLIVER_REACH
#define GBAA_SLIVER_REACH 1.5   // a neighbour's edge this far from its centre can reach this pixel
#endif
#ifndef GBAA_SLIVER_CAP
#define GBAA_SLIVER_CAP 0.5     // a half-plane that misses a pixel's centre covers at most half of it
#endif
#ifndef GBAA_ALONG_EDGE_CLAMP
#define GBAA_ALONG_EDGE_CLAMP 1.5   // an edge pixel's own part stays within this factor of c
#endif

uniform sampler2D u_depth;   // RT2: view depth (0: background), material id
uniform sampler2D u_edge;    // RT7: distances to the surface's edge along +x, -x, +y, -y
uniform sampler2D u_hdr;     // linear HDR RGBA (premultiplied where transparent)
uniform float u_exposure;    // linear scale, 2^EV
// 1: the background pixels' radiance is u_background, not u_hdr's (where the lighting
// pass wrote the display image and the surfaces' radiance alone: Renderer.run_lighting)
uniform float u_uniform_background;
uniform vec4 u_background;
// GBAA_CORRECT: the radiance (the HDR image's units) past which a neighbour is left out
// of the area mean: past the display's white (GBAA_SPILL times
// app/reference/antialiasing.py gbaa_saturation, over the exposure)
uniform float u_spill;

out vec4 frag_color;

const ivec2 STEPS[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));

ivec2 g_last;

vec2 surface_at(ivec2 px) {
    return texelFetch(u_depth, clamp(px, ivec2(0), g_last), 0).xy;
}

#if QUAD_NEIGHBOURS
#if FINE_DERIVATIVES
#define QUAD_DFDX dFdxFine
#define QUAD_DFDY dFdyFine
#else
#define QUAD_DFDX dFdx
#define QUAD_DFDY dFdy
#endif
// Whether this lane is the first (left, lower) of its quad along x and y: the (fine)
// derivative of the position's parity is +1 where a quad's first lane is even.
bvec2 g_first;
// The lane's step to its neighbour outside the quad, along x and along y.
ivec2 g_out;

void quad_lanes(ivec2 px) {
    vec2 parity = vec2(px & 1);
    vec2 even_first = vec2(QUAD_DFDX(parity.x), QUAD_DFDY(parity.y));
    g_first = equal(equal(parity, vec2(0.0)), greaterThan(even_first, vec2(0.0)));
    g_out = ivec2(g_first.x ? -1 : 1, g_first.y ? -1 : 1);
}

// The 4-neighbours (+x, -x, +y, -y) of value v, given the values at the neighbours
// outside the quad: the ones inside are v plus or minus its derivative (exactly
// the neighbour's value where the two lie within a factor 2 of each other, Sterbenz's
// lemma; a surface's depth and a background's 0 stay exact, an id is an integer).
// Derivatives are taken here, in uniform control flow, every lane alive.
vec4[4] quad_around(vec4 v, vec4 out_x, vec4 out_y) {
    vec4 in_x = g_first.x ? v + QUAD_DFDX(v) : v - QUAD_DFDX(v);
    vec4 in_y = g_first.y ? v + QUAD_DFDY(v) : v - QUAD_DFDY(v);
    return vec4[4](g_first.x ? in_x : out_x, g_first.x ? out_x : in_x,
                   g_first.y ? in_y : out_y, g_first.y ? out_y : in_y);
}
#endif

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

// Whether RT2 texels a and b hold the same surface (neither the background).
bool same_surface(vec2 a, vec2 b) {
    return a.x > 0.0 && b.x > 0.0 && a.y == b.y &&
           abs(a.x - b.x) <= GBAA_DEPTH_TOLERANCE * min(a.x, b.x);
}

// Radiance c of a surface pixel moved `shift` pixels from its centre (to the centroid of
// the part of the pixel its surface covers, not the centre it was shaded at), linear through
// c and the radiance b of the pixel beyond it on the other side, which holds the same
// surface. A rim's shading falls steeply toward the silhouette (n.l, n.v to 0): with the
// centre's shading alone a rim lit from the viewer drew a line darker inside and brighter
// outside than the area mean (docs/accuracy.md, "Every pixel"). The pixel beyond need not
// be marked: the HDR image holds every surface pixel.
vec4 centroid_radiance(vec4 c, vec4 b, float shift) {
    // A pixel's own part is moved inward only where the shading falls toward the rim
    // (brighter inside): where it rises (sheen, a grazing highlight) the line through two
    // centres undershoots the peak at the silhouette, and the centre's own measured closer.
    if (shift < 0.0 && dot(c.rgb, vec3(1.0)) >= dot(b.rgb, vec3(1.0))) return c;
    // within a factor of 2 of c: a highlight or a texture beyond is no slope
    return clamp(c + shift * (c - b), 0.5 * c, 2.0 * c);
}

// The display value of linear HDR RGBA c: exposed, tone mapped and encoded as
// passes/post.frag does (straight alpha where the background is transparent).
vec4 display_of(vec4 c) {
#if STRAIGHT_ALPHA
    float a = clamp(c.a, 0.0, 1.0);
    vec3 rgb = (a > 0.0 ? c.rgb / a : vec3(0.0)) * u_exposure;
    return vec4(srgb_encode(tonemap_selected(rgb)), a);
#else
    return vec4(srgb_encode(tonemap_selected(c.rgb * u_exposure)), 1.0);
#endif
}

// A pixel's area mean from its centre's radiance c and its 4 neighbours' (the same
// surface), to second order: the midpoint rule misses (f_xx + f_yy) / 24 of the box
// filter's integral, and (sum of the neighbours - 4c) is the 5-point Laplacian; a filter
// whose variance per axis, 2/24, is the unit box's 1/12. Its weights (20/24 and 1/24 each)
// are positive, so the mean is never negative; unclamped: a clamp to a factor of c held a
// pixel just past a light's terminator (c = 0) at 0, where its area is lit
// (docs/accuracy.md, "Every pixel"). A neighbour whose brightest channel is past u_spill
// counts as c: its 1/24 alone would turn this pixel white (a highlight smaller than a
// pixel at its centre drew a white plus around it, where the area truth is not white).
vec4 interior_radiance(vec4 c, vec4 n[4]) {
    vec4 sum = vec4(0.0);
    for (int k = 0; k < 4; ++k) {
        sum += max(n[k].r, max(n[k].g, n[k].b)) > u_spill ? c : n[k];
    }
    vec4 mean = c + (sum - 4.0 * c) / 24.0;
    return vec4(mean.rgb, c.a);
}

// The interior correction of a marked pixel's own part: the second differences of the
// axes whose two neighbours both hold this pixel's surface (along a silhouette, the axis
// across its normal), each over 24, held within GBAA_ALONG_EDGE_CLAMP of c (docs/antialiasing.md:
// unclamped it barely moves the every-pixel error, and the clamp keeps the default's pixels).
vec4 along_edge(vec4 c, vec2 centre, vec2 around[4], vec4 n[4]) {
    vec4 delta = vec4(0.0);
    for (int axis = 0; axis < 2; ++axis) {
        int k = 2 * axis;
        if (same_surface(centre, around[k]) && same_surface(centre, around[k + 1])) {
            delta += (n[k] + n[k + 1] - 2.0 * c) / 24.0;
        }
    }
    vec3 rgb = clamp(c.rgb + delta.rgb, c.rgb / GBAA_ALONG_EDGE_CLAMP, c.rgb * GBAA_ALONG_EDGE_CLAMP);
    return vec4(rgb - c.rgb, 0.0);
}

// The area of a pixel on its surface's side of a straight edge (the box filter of a
// half-plane, exact at the pixel's corners too): the edge crosses the pixel's axes at d
// (toward the edge) and e (across) from the centre of the pixel whose distances they are,
// and the pixel measured lies `offset` pixels from that centre toward the edge. With the
// line's normal (1/d, 1/e) unnormalised (the areas are ratios), the pixel's centre lies
// s = 1 - offset/d inside it: a band where the edge leaves through two opposite sides
// (0.5 + s/u), and a corner triangle (t^2 / 2uv, t from the corner) beyond.
float box_coverage(float d, float e, float offset) {
    float a = 1.0 / max(d, 1e-4), b = 1.0 / max(e, 1e-4);   // an edge through the centre: 1/2
    float u = max(a, b), v = min(a, b);
    float s = 1.0 - offset * a;
    float t = 0.5 * (u + v) - abs(s);
    if (t <= 0.0) return s > 0.0 ? 1.0 : 0.0;
    if (abs(s) <= 0.5 * (u - v)) return 0.5 + s / u;
    float corner = t * t / (2.0 * u * v);
    return s > 0.0 ? 1.0 - corner : corner;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
#ifdef GBAA_CORRECT
    // An interior pixel (the depth test): its centre's radiance moved to its area mean
    // (interior_radiance), its 4 neighbours its own surface by the mark.
    g_last = textureSize(u_hdr, 0) - 1;
    vec4 here = texelFetch(u_hdr, px, 0);
    vec4 colours[4];
#if QUAD_NEIGHBOURS
    quad_lanes(px);
    colours = quad_around(here, texelFetch(u_hdr, clamp(px + ivec2(g_out.x, 0), ivec2(0), g_last), 0),
                          texelFetch(u_hdr, clamp(px + ivec2(0, g_out.y), ivec2(0), g_last), 0));
#else
    for (int k = 0; k < 4; ++k) colours[k] = texelFetch(u_hdr, clamp(px + STEPS[k], ivec2(0), g_last), 0);
#endif
    frag_color = display_of(interior_radiance(here, colours));
#else
    g_last = textureSize(u_depth, 0) - 1;
    vec2 centre = surface_at(px);
    vec2 around[4];
#if QUAD_NEIGHBOURS
    quad_lanes(px);
    vec4 surfaces[4] = quad_around(vec4(centre, 0.0, 0.0),
                                   vec4(surface_at(px + ivec2(g_out.x, 0)), 0.0, 0.0),
                                   vec4(surface_at(px + ivec2(0, g_out.y)), 0.0, 0.0));
    for (int k = 0; k < 4; ++k) around[k] = surfaces[k].xy;
#else
    for (int k = 0; k < 4; ++k) around[k] = surface_at(px + STEPS[k]);
#endif
    // another surface in a 4-neighbour (in_front either way), in arithmetic
    bvec4 other = bvec4(false);
    for (int k = 0; k < 4; ++k) {
        vec2 q = around[k];
        other[k] = (q.x > 0.0) != (centre.x > 0.0) || (centre.x > 0.0 &&
                   (q.y != centre.y || abs(q.x - centre.x) > GBAA_DEPTH_TOLERANCE * min(q.x, centre.x)));
    }
#ifdef GBAA_MARK
    // 0: a silhouette pixel (the resolve's); 1: an interior surface pixel (the interior
    // correction's); 0.5: the background away from every silhouette (neither's)
    gl_FragDepth = any(other) ? 0.0 : centre.x > 0.0 ? 1.0 : 0.5;
    frag_color = vec4(0.0);
#else
    // this pixel's own edge: the nearest toward a neighbour behind it
    vec4 own = texelFetch(u_edge, px, 0);
    vec4 edges[4];   // the neighbours' edge distances
    vec4 here = radiance(px, centre);
    vec4 colours[4];   // the neighbours' radiance
#if QUAD_NEIGHBOURS
    edges = quad_around(own, texelFetch(u_edge, clamp(px + ivec2(g_out.x, 0), ivec2(0), g_last), 0),
                        texelFetch(u_edge, clamp(px + ivec2(0, g_out.y), ivec2(0), g_last), 0));
    colours = quad_around(here, radiance(px + ivec2(g_out.x, 0), g_out.x > 0 ? around[0] : around[1]),
                          radiance(px + ivec2(0, g_out.y), g_out.y > 0 ? around[2] : around[3]));
#else
    for (int k = 0; k < 4; ++k) {
        edges[k] = texelFetch(u_edge, clamp(px + STEPS[k], ivec2(0), g_last), 0);
        colours[k] = radiance(px + STEPS[k], around[k]);
    }
#endif
    float weight[4] = float[4](0.0, 0.0, 0.0, 0.0);
    float nearest = GBAA_EXACT > 0 ? 1.0 : 0.5;
    int toward = -1;
    for (int k = 0; k < 4; ++k) {
        if (in_front(centre, around[k]) && own[k] < nearest) {
            nearest = own[k];
            toward = k;
        }
    }
#if GBAA_EXACT
    if (toward >= 0) {
        float across = toward < 2 ? min(own.z, own.w) : min(own.x, own.y);
        weight[toward] = 1.0 - box_coverage(nearest, across, 0.0);
    }
#else
    if (toward >= 0) weight[toward] = 0.5 - nearest;
#endif
    // the neighbours in front whose edge reaches into this pixel, along their major axis
    float front[4] = float[4](0.0, 0.0, 0.0, 0.0);
    for (int k = 0; k < 4; ++k) {
        if (!in_front(around[k], centre)) continue;
        vec4 theirs = edges[k];
        int back = k ^ 1;   // from the neighbour toward this pixel
        float d = theirs[back];
        float across = k < 2 ? min(theirs.z, theirs.w) : min(theirs.x, theirs.y);
#if GBAA_EXACT
        // d past 1: the edge passes this pixel's centre as the neighbour sees it (a slanted
        // or curved edge half over the pixel), the area capped as the centre is not covered
        if (d > 0.0 && d < GBAA_SLIVER_REACH) front[k] = min(box_coverage(d, across, 1.0), GBAA_SLIVER_CAP);
#else
        if (d > 0.5 && d < 1.0 && d <= GBAA_AXIS_TIE * across) front[k] = d - 0.5;
#endif
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
    // own part: covered from -0.5 to `nearest` toward the edge, its centroid (0.5 - nearest)/2
    // away from the centre, the pixel beyond it the opposite 4-neighbour (toward ^ 1)
    vec4 c = here;
    if (toward >= 0 && same_surface(centre, around[toward ^ 1])) {
        c = centroid_radiance(here, colours[toward ^ 1], -0.5 * weight[toward]);
    }
#if GBAA_EXACT
    c += along_edge(here, centre, around, colours);
#endif
    c *= 1.0 - min(total, 1.0);
    // A neighbour's sliver: from 0.5 to d of its centre, its centroid (0.5 + d)/2 toward
    // this pixel, the pixel beyond it two steps away. Only the widest sliver is moved to its
    // centroid: a second one (a pixel between two nearer surfaces along one axis) is rare, and
    // each costs two more fetches for every resolved pixel (llvmpipe runs both sides of a
    // branch for a whole block).
    int widest = -1;
    for (int k = 0; k < 4; ++k) {
        if (k != toward && weight[k] > 0.0 && (widest < 0 || weight[k] > weight[widest])) {
            widest = k;
        }
    }
    vec4 sliver[4] = colours;
    if (widest >= 0) {
        ivec2 far_px = px + 2 * STEPS[widest];
        vec2 beyond = surface_at(far_px);
        if (same_surface(around[widest], beyond)) {
            float shift = 0.5 * (weight[widest] + 1.0);   // (0.5 + d)/2, d = weight + 0.5
            sliver[widest] = centroid_radiance(colours[widest], radiance(far_px, beyond), shift);
        }
    }
    for (int k = 0; k < 4; ++k) {
        if (weight[k] > 0.0) c += weight[k] * scale * sliver[k];
    }
    frag_color = display_of(c);
#endif
#endif
}
