// Tiled light culling on OpenGL 3.3: screen tiles of TILE_SIZE^2 pixels, each with a
// bitmask of the local (point and spot) lights whose range reaches its surfaces.
// Twin: app/reference/tiles.py.
#ifndef PBS_TILES_GLSL
#define PBS_TILES_GLSL

#ifndef TILE_SIZE
#define TILE_SIZE 8
#endif

// Bits of a tile's depth mask: the slab between its nearest and farthest surface is cut
// into DEPTH_BINS equal slices, and bit b says a surface of the tile lies in slice b.
const int DEPTH_BINS = 32;
// A slice's ends widen by this fraction of z_max before the box test: float32 rounding of
// a depth's slice index and of the slice's ends can put a surface a few ulps outside it.
const float Z_SLACK = 1e-5;

// Slices per metre of the slab [z_min, z_max]; the width has a floor so that a tile of a
// single depth (a wall seen head-on) still gets a finite scale (its surfaces: slice 0).
float depth_bin_scale(float z_min, float z_max) {
    return float(DEPTH_BINS) / max(z_max - z_min, 1e-20);
}

// Harada et al. 2012, "Forward+: A Step Toward Film-Quality Rendering in Real Time"
// (2.5D culling): the slice, 0 ... DEPTH_BINS - 1, of view depth z; outside clamps to
// the ends. Both culling passes call this one function, and it is monotonic in z, so a
// light whose depth extent contains a surface's depth also contains its slice.
int depth_bin(float z, float z_min, float bin_scale) {
    return int(clamp((z - z_min) * bin_scale, 0.0, float(DEPTH_BINS - 1)));
}

// Bits lo ... hi set (0 <= lo <= hi < 32).
uint bin_range_mask(int lo, int hi) {
    return (0xFFFFFFFFu >> uint(31 - (hi - lo))) << uint(lo);
}

// Index of the lowest set bit of a non-zero mask (findLSB is GLSL 4.00): isolate it
// with x & -x; that power of two converts to float exactly, and its exponent field is
// the index (+127). No table: a table indexed per pixel is a gather on a SIMD rasteriser
// such as llvmpipe, and this runs once per light a pixel visits.
int lowest_bit(uint mask) {
    uint lsb = mask & (~mask + 1u);
    return int(floatBitsToUint(float(lsb)) >> 23) - 127;
}

// Index of the highest set bit of a non-zero mask (findMSB is GLSL 4.00): smear it into
// every lower bit and keep only it, then as lowest_bit (a float of the mask itself could
// round up to the next power of two).
int highest_bit(uint mask) {
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    return lowest_bit(mask ^ (mask >> 1));
}

// --- a tile's light mask: RGBA32UI texels of four 32-bit words ---

// Bit c set where word c of q is non-zero.
uint quad_occupancy(uvec4 q) {
    uvec4 nonzero = uvec4(notEqual(q, uvec4(0u)));
    return nonzero.x | (nonzero.y << 1) | (nonzero.z << 2) | (nonzero.w << 3);
}

// Word c (0 ... 3) of q, by selects (a dynamic component index may go through memory).
uint quad_word(uvec4 q, int c) {
    return c < 2 ? (c == 0 ? q.x : q.y) : (c == 2 ? q.z : q.w);
}

// On to the next word of q that holds a light: `words` has a bit for each word not yet
// visited that is non-zero; w and bits become that word's index and value. Nothing
// happens when none is left.
void next_quad_word(uvec4 q, inout uint words, inout int w, inout uint bits) {
    if (words != 0u) {
        w = lowest_bit(words);
        words &= words - 1u;
        bits = quad_word(q, w);
    }
}

// q with bit b of word c set to 1.
uvec4 quad_bit(int c, int b) {
    return uvec4(equal(ivec4(c), ivec4(0, 1, 2, 3))) << uint(b);
}

// --- ... in the lighting pass ---
// The culler writes TILE_QUADS RGBA32UI texels per tile: light 128 k + 32 c + b is bit b
// of component c of texel k. The lighting pass holds up to 8 texels (1024 lights, a
// "chunk") in registers and visits the set bits of the non-zero words in ascending order.
// Eight named fields, not an array: llvmpipe keeps a dynamically indexed local array in
// memory, and indexing one per light slowed the lighting pass (measured in
// docs/performance.md, "The light loop").
#ifdef TILE_QUADS
struct TileMask {
    uvec4 q0, q1, q2, q3, q4, q5, q6, q7;
};

// Texel k (0 ... 7) of chunk `chunk` of the tile's mask, zero past the tile's last texel.
uvec4 tile_quad(usampler2D masks, ivec2 tile, int chunk, int k) {
    int texel = chunk * 8 + k;
    if (texel >= TILE_QUADS) return uvec4(0u);
    return texelFetch(masks, ivec2(tile.x * TILE_QUADS + texel, tile.y), 0);
}

TileMask load_tile_mask(usampler2D masks, ivec2 tile, int chunk) {
    TileMask m = TileMask(uvec4(0u), uvec4(0u), uvec4(0u), uvec4(0u),
                          uvec4(0u), uvec4(0u), uvec4(0u), uvec4(0u));
    m.q0 = tile_quad(masks, tile, chunk, 0);
#if TILE_QUADS > 1
    m.q1 = tile_quad(masks, tile, chunk, 1);
#endif
#if TILE_QUADS > 2
    m.q2 = tile_quad(masks, tile, chunk, 2);
#endif
#if TILE_QUADS > 3
    m.q3 = tile_quad(masks, tile, chunk, 3);
#endif
#if TILE_QUADS > 4
    m.q4 = tile_quad(masks, tile, chunk, 4);
#endif
#if TILE_QUADS > 5
    m.q5 = tile_quad(masks, tile, chunk, 5);
#endif
#if TILE_QUADS > 6
    m.q6 = tile_quad(masks, tile, chunk, 6);
#endif
#if TILE_QUADS > 7
    m.q7 = tile_quad(masks, tile, chunk, 7);
#endif
    return m;
}

// Bit w set where word w (0 ... 31) of the chunk holds a light.
uint tile_occupancy(TileMask m) {
    return quad_occupancy(m.q0) | (quad_occupancy(m.q1) << 4)
         | (quad_occupancy(m.q2) << 8) | (quad_occupancy(m.q3) << 12)
         | (quad_occupancy(m.q4) << 16) | (quad_occupancy(m.q5) << 20)
         | (quad_occupancy(m.q6) << 24) | (quad_occupancy(m.q7) << 28);
}

// Word w (0 ... 31) of the chunk: selects, which stay in registers.
uint tile_word(TileMask m, int w) {
    int k = w >> 2;
    uvec4 q = k < 4 ? (k < 2 ? (k == 0 ? m.q0 : m.q1) : (k == 2 ? m.q2 : m.q3))
                    : (k < 6 ? (k == 4 ? m.q4 : m.q5) : (k == 6 ? m.q6 : m.q7));
    return quad_word(q, w & 3);
}

// next_quad_word for a chunk of up to 32 words.
void next_tile_word(TileMask m, inout uint words, inout int w, inout uint bits) {
    if (words != 0u) {
        w = lowest_bit(words);
        words &= words - 1u;
        bits = tile_word(m, w);
    }
}
#endif

// --- the culling tests of one tile (or group of tiles) against one light ---

// What every test of one tile shares, computed once per fragment: llvmpipe's JIT moves
// nothing out of a loop, so the culling passes' loops over lights would otherwise compute
// these again for every light (docs/performance.md, "Tiled culling").
struct TileFrustum {
    float z_min, z_max;       // the depth slab of the tile's surfaces
    uint depth_mask;          // its occupied slices (the group pass: unused)
    float scale;              // depth_bin_scale(z_min, z_max): slices per metre
    float slack;              // Z_SLACK * z_max
    vec2 k_min, k_max;        // the side planes: x = k depth (ndc * tan_half_fov)
    vec2 norm_min, norm_max;  // sqrt(1 + k^2): the length of each side plane's normal
};

// The frustum of the pixels whose NDC lie in [ndc_min, ndc_max], over [z_min, z_max].
TileFrustum tile_frustum(vec2 ndc_min, vec2 ndc_max, vec2 tan_half_fov, float z_min,
                         float z_max, uint depth_mask) {
    TileFrustum f;
    f.z_min = z_min;
    f.z_max = z_max;
    f.depth_mask = depth_mask;
    f.scale = depth_bin_scale(z_min, z_max);
    f.slack = Z_SLACK * z_max;
    f.k_min = ndc_min * tan_half_fov;
    f.k_max = ndc_max * tan_half_fov;
    f.norm_min = vec2(sqrt(1.0 + f.k_min.x * f.k_min.x), sqrt(1.0 + f.k_min.y * f.k_min.y));
    f.norm_max = vec2(sqrt(1.0 + f.k_max.x * f.k_max.x), sqrt(1.0 + f.k_max.y * f.k_max.y));
    return f;
}

// Harada et al. 2012: does a sphere (view-space centre c with depth d = -c.z, radius r)
// lie inside the depth slab [z_min, z_max] and inside each of the four side planes of the
// tile's frustum, each tested on its own? Conservative but loose at the frustum's
// corners: for spheres much wider than the tile it accepts every centre in the r x r
// squares beyond the corners of the tile's cross-section, where only a quarter disc of
// radius r reaches it.
bool tile_planes_reach(TileFrustum f, vec3 c, float r) {
    float d = -c.z;
    if (d + r < f.z_min || d - r > f.z_max) return false;
    // A point is right of the left plane when x >= ndc_min.x tan_x d; the plane's unit
    // normal in (x, d) is (1, -k)/sqrt(1 + k^2) with k = ndc_min.x tan_x.
    if (c.x - f.k_min.x * d < -r * f.norm_min.x) return false;
    if (f.k_max.x * d - c.x < -r * f.norm_max.x) return false;
    if (c.y - f.k_min.y * d < -r * f.norm_min.y) return false;
    if (f.k_max.y * d - c.y < -r * f.norm_max.y) return false;
    return true;
}

// The view-space bounding box, in (x, y, depth), of the tile's frustum between depths
// z_lo and z_hi: x = k depth across the slab, so each side of the box is at z_lo or at
// z_hi.
void tile_box(TileFrustum f, float z_lo, float z_hi, out vec3 lo, out vec3 hi) {
    lo = vec3(min(f.k_min * z_lo, f.k_min * z_hi), z_lo);
    hi = vec3(max(f.k_max * z_lo, f.k_max * z_hi), z_hi);
}

// Arvo 1990, "A Simple Method for Box-Sphere Intersection Testing": does the sphere reach
// the box [lo, hi] (in (x, y, depth))? The exact distance to the box, so tight at corners
// where the planes are loose; the planes are tighter along a deep, slanted frustum, so
// the culler asks both.
bool box_reach(vec3 lo, vec3 hi, vec3 c, float r) {
    vec3 q = vec3(c.xy, -c.z);
    vec3 gap = max(max(lo - q, q - hi), 0.0);
    return dot(gap, gap) <= r * r;
}

// The sphere reaches the view-space box of the tile's frustum between z_lo and z_hi.
bool tile_box_reach(TileFrustum f, vec3 c, float r, float z_lo, float z_hi) {
    vec3 lo, hi;
    tile_box(f, z_lo, z_hi, lo, hi);
    return box_reach(lo, hi, c, r);
}

// Wronski 2017, "Cull that cone!": does a spot light's cone (apex a, unit axis u, outer
// half-angle with cosine cos_a and sine sin_a, length len) reach the sphere (centre q,
// radius rho)? It misses when q lies more than rho outside the cone's side, beyond its
// length, or behind its apex. Behind the apex the side distance underestimates the true
// one (Cauchy-Schwarz), so the test stays conservative there too.
bool cone_reaches_sphere(vec3 a, vec3 u, float cos_a, float sin_a, float len, vec3 q,
                         float rho) {
    vec3 v = q - a;
    float along = dot(v, u);
    float side = cos_a * sqrt(max(dot(v, v) - along * along, 0.0)) - along * sin_a;
    return side <= rho && along <= rho + len && along >= -rho;
}

// A spot light (centre c and range r, axis spot.xyz in view space, cone cosine spot.w and
// sine sin_a) reaches the bounding sphere of the tile frustum's view-space box between
// depths z_lo and z_hi. Coordinates are (x, y, depth) as in box_reach, so the z flip.
bool cone_reaches_tile(TileFrustum f, vec3 c, float r, vec4 spot, float sin_a, float z_lo,
                       float z_hi) {
    vec3 lo, hi;
    tile_box(f, z_lo, z_hi, lo, hi);
    // The sphere grows by 1e-4 of its size: float32 rounding of the centre and the side
    // distance must never cull a light whose cone (barely) reaches a surface.
    float rho = 0.5 * length(hi - lo) * (1.0 + 1e-4);
    return cone_reaches_sphere(vec3(c.xy, -c.z), vec3(spot.xy, -spot.z), spot.w, sin_a, r,
                               0.5 * (lo + hi), rho);
}

// The culler's decision for one (tile, light) pair, in two stages (light_cull.frag runs
// the cone stage only for the spot lights that pass the sphere stage). 2.5D culling
// (Harada et al. 2012): the sphere's depth extent [d - r, d + r] must cover a slice of
// the tile's depth mask that holds a surface; then the sphere must reach the frustum's
// box between the nearest and farthest of those slices, and pass the planes; a spot
// light's cone must reach the bounding sphere of one of those slices' boxes. Every step
// is conservative.

// The ends of slice b, widened by the slack.
float slice_near(TileFrustum f, int b) {
    return f.z_min + float(b) / f.scale - f.slack;
}

float slice_far(TileFrustum f, int b) {
    return f.z_min + float(b + 1) / f.scale + f.slack;
}

// The occupied slices within the sphere's depth extent (0: none).
uint sphere_slices(TileFrustum f, vec3 c, float r) {
    float d = -c.z;
    if (d + r < f.z_min || d - r > f.z_max) return 0u;
    return f.depth_mask & bin_range_mask(depth_bin(d - r, f.z_min, f.scale),
                                         depth_bin(d + r, f.z_min, f.scale));
}

// The sphere stage: the occupied slices within the sphere's depth extent, 0 when the
// sphere misses the tile.
uint sphere_reaches_tile(TileFrustum f, vec3 c, float r) {
    uint hits = sphere_slices(f, c, r);
    if (hits == 0u) return 0u;
    if (!(tile_box_reach(f, c, r, slice_near(f, lowest_bit(hits)),
                         slice_far(f, highest_bit(hits)))
          && tile_planes_reach(f, c, r))) {
        return 0u;
    }
    return hits;
}

// Does the cone reach a sphere around every slice's sphere (cone_reaches_tile) from the
// lowest to the highest slice of `hits`? The box of that span holds each slice's box, so
// each slice's centre lies within half the span's diagonal of the span's centre, and each
// slice's radius is at most half the diagonal of the span's cross-section and one slice's
// depth; the sum (grown by 1e-3, beyond the slices' own 1e-4 and float32 rounding) holds
// every slice sphere. Each of cone_reaches_sphere's three distances moves by at most the
// distance its centre moves, so a cone that misses this sphere misses every slice's: the
// pre-test changes no decision, and it spares the loop over slices for most of the spot
// lights the cone stage culls.
bool cone_reaches_span(TileFrustum f, vec3 c, float r, vec4 spot, float sin_a, uint hits) {
    vec3 lo, hi;
    tile_box(f, slice_near(f, lowest_bit(hits)), slice_far(f, highest_bit(hits)), lo, hi);
    vec3 span = hi - lo;
    float slice_depth = 1.0 / f.scale + 2.0 * f.slack;
    float rho = 0.5 * (length(span) + length(vec3(span.xy, slice_depth))) * (1.0 + 1e-3);
    return cone_reaches_sphere(vec3(c.xy, -c.z), vec3(spot.xy, -spot.z), spot.w, sin_a, r,
                               0.5 * (lo + hi), rho);
}

// The cone stage: does a spot light's cone (spot.xyz its axis, spot.w the cosine of its
// outer angle) reach the box of one of the slices `hits` (non-zero) on its own? One
// sphere around all of them would span the tile's whole depth range (a floor seen at a
// grazing angle); it serves only to leave out the cones that miss them all at once.
bool cone_reaches_slices(TileFrustum f, vec3 c, float r, vec4 spot, uint hits) {
    float sin_a = sqrt(max(1.0 - spot.w * spot.w, 0.0));
    if (!cone_reaches_span(f, c, r, spot, sin_a, hits)) return false;
    bool reach = false;
    // Top-tested: as a do-while nested in light_cull.frag's loop over candidates, llvmpipe
    // (Mesa 22.3) culled 14 of 2731 (tile, spot) pairs it should keep.
    while (!reach && hits != 0u) {
        int b = lowest_bit(hits);
        hits &= hits - 1u;
        reach = cone_reaches_tile(f, c, r, spot, sin_a, slice_near(f, b), slice_far(f, b));
    }
    return reach;
}

#endif
