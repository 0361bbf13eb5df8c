// Tiled light culling on OpenGL 3.3: screen tiles of TILE_SIZE^2 pixels, each with a
// bitmask of the local (point and spot) lights whose range reaches its surfaces.
// Twin: app/reference/tiles.py.
#ifndef PBS_TILES_GLSL
#define PBS_TILES_GLSL

#ifndef TILE_SIZE
#define TILE_SIZE 16
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

// Harada et al. 2012: does a sphere (view-space centre c with depth d = -c.z, radius r)
// lie inside the depth slab [z_min, z_max] and inside each of the four side planes of the
// tile's frustum (the pixels whose NDC lie in [ndc_min, ndc_max]), each tested on its own?
// Conservative but loose at the frustum's corners: for spheres much wider than the tile
// it accepts every centre in the r x r squares beyond the corners of the tile's cross-
// section, where only a quarter disc of radius r reaches it.
bool tile_planes_reach(vec3 c, float r, vec2 ndc_min, vec2 ndc_max, vec2 tan_half_fov,
                       float z_min, float z_max) {
    float d = -c.z;
    if (d + r < z_min || d - r > z_max) return false;
    // A point is right of the left plane when x >= ndc_min.x tan_x d; the plane's unit
    // normal in (x, d) is (1, -k)/sqrt(1 + k^2) with k = ndc_min.x tan_x.
    vec2 k_min = ndc_min * tan_half_fov;
    vec2 k_max = ndc_max * tan_half_fov;
    if (c.x - k_min.x * d < -r * sqrt(1.0 + k_min.x * k_min.x)) return false;
    if (k_max.x * d - c.x < -r * sqrt(1.0 + k_max.x * k_max.x)) return false;
    if (c.y - k_min.y * d < -r * sqrt(1.0 + k_min.y * k_min.y)) return false;
    if (k_max.y * d - c.y < -r * sqrt(1.0 + k_max.y * k_max.y)) return false;
    return true;
}

// The view-space bounding box, in (x, y, depth), of the tile's frustum (the pixels whose
// NDC lie in [ndc_min, ndc_max]) between depths z_lo and z_hi: x = k depth across the
// slab, so each side of the box is at z_lo or at z_hi.
void tile_box(vec2 ndc_min, vec2 ndc_max, vec2 tan_half_fov, float z_lo, float z_hi,
              out vec3 lo, out vec3 hi) {
    vec2 k_min = ndc_min * tan_half_fov;
    vec2 k_max = ndc_max * tan_half_fov;
    lo = vec3(min(k_min * z_lo, k_min * z_hi), z_lo);
    hi = vec3(max(k_max * z_lo, k_max * z_hi), z_hi);
}

// Arvo 1990, "A Simple Method for Box-Sphere Intersection Testing": does the sphere reach
// the view-space bounding box of the tile's frustum between depths z_lo and z_hi? The
// exact distance to the box, so tight at corners where the planes are loose; the planes
// are tighter along a deep, slanted frustum, so the culler asks both.
bool tile_box_reach(vec3 c, float r, vec2 ndc_min, vec2 ndc_max, vec2 tan_half_fov,
                    float z_lo, float z_hi) {
    vec3 lo, hi;
    tile_box(ndc_min, ndc_max, tan_half_fov, z_lo, z_hi, lo, hi);
    vec3 q = vec3(c.xy, -c.z);
    vec3 gap = max(max(lo - q, q - hi), 0.0);
    return dot(gap, gap) <= r * r;
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

// A spot light (axis u in view space, cone cosine and sine cos_a, sin_a) reaches the
// bounding sphere of the tile frustum's view-space box between depths z_lo and z_hi.
// Coordinates are (x, y, depth) as in tile_box_reach, so the axis's z flips.
bool cone_reaches_tile(vec3 c, float r, vec3 u, float cos_a, float sin_a, vec2 ndc_min,
                       vec2 ndc_max, vec2 tan_half_fov, float z_lo, float z_hi) {
    vec3 lo, hi;
    tile_box(ndc_min, ndc_max, tan_half_fov, z_lo, z_hi, lo, hi);
    // The sphere grows by 1e-4 of its size: float32 rounding of the centre and the side
    // distance must never cull a light whose cone (barely) reaches a surface.
    float rho = 0.5 * length(hi - lo) * (1.0 + 1e-4);
    return cone_reaches_sphere(vec3(c.xy, -c.z), vec3(u.xy, -u.z), cos_a, sin_a, r,
                               0.5 * (lo + hi), rho);
}

// The culler's decision for one (tile, light) pair. 2.5D culling (Harada et al. 2012):
// the sphere's depth extent [d - r, d + r] must cover a slice of the tile's depth mask
// that holds a surface; then the sphere must reach the frustum's box between the nearest
// and farthest of those slices, and pass the planes; a spot light's cone (spot.w =
// cos of the outer angle, spot.xyz its axis; spot.w < -1 for a point light) must reach
// the bounding sphere of one of those slices' boxes. Every step is conservative.
bool light_reaches_tile(vec3 c, float r, vec4 spot, vec2 ndc_min, vec2 ndc_max,
                        vec2 tan_half_fov, float z_min, float z_max, uint depth_mask) {
    float d = -c.z;
    if (d + r < z_min || d - r > z_max) return false;
    float scale = depth_bin_scale(z_min, z_max);
    uint hits = depth_mask & bin_range_mask(depth_bin(d - r, z_min, scale),
                                            depth_bin(d + r, z_min, scale));
    if (hits == 0u) return false;
    float slack = Z_SLACK * z_max;
    float z_lo = z_min + float(lowest_bit(hits)) / scale - slack;
    float z_hi = z_min + float(highest_bit(hits) + 1) / scale + slack;
    if (!(tile_box_reach(c, r, ndc_min, ndc_max, tan_half_fov, z_lo, z_hi)
          && tile_planes_reach(c, r, ndc_min, ndc_max, tan_half_fov, z_min, z_max))) {
        return false;
    }
    if (spot.w < -1.0) return true;  // a point light: no cone
    // The cone against each occupied slice's box on its own: one sphere around all of them
    // would span the tile's whole depth range (a floor seen at a grazing angle).
    float sin_a = sqrt(max(1.0 - spot.w * spot.w, 0.0));
    while (hits != 0u) {
        int b = lowest_bit(hits);
        hits &= hits - 1u;
        float lo = z_min + float(b) / scale - slack;
        float hi = z_min + float(b + 1) / scale + slack;
        if (cone_reaches_tile(c, r, spot.xyz, spot.w, sin_a, ndc_min, ndc_max, tan_half_fov,
                              lo, hi)) {
            return true;
        }
    }
    return false;
}

#endif
