// Tiled light culling on OpenGL 3.3: screen tiles of TILE_SIZE^2 pixels, each with a
// bitmask of the local (point and spot) lights whose range reaches its surfaces.
// Twin: app/reference/tiles.py.
#ifndef PBS_TILES_GLSL
#define PBS_TILES_GLSL

#ifndef TILE_SIZE
#define TILE_SIZE 16
#endif

// Does a sphere (view-space centre c with depth d = -c.z, radius r) reach the tile's
// sub-frustum: the pixels whose NDC lie in [ndc_min, ndc_max], between the view depths
// z_min and z_max? Conservative: each side plane and the depth slab are tested on
// their own (Harada et al. 2012, "Forward+"), so a sphere near a corner may pass.
bool sphere_reaches_tile(vec3 c, float r, vec2 ndc_min, vec2 ndc_max, vec2 tan_half_fov,
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

// Index of the lowest set bit of a non-zero mask (findLSB is GLSL 4.00): isolate it
// with x & -x, then a de Bruijn multiply maps each power of two to a distinct 5-bit key.
const int DEBRUIJN_BIT[32] = int[32](
    0, 1, 28, 2, 29, 14, 24, 3, 30, 22, 20, 15, 25, 17, 4, 8,
    31, 27, 13, 23, 21, 19, 16, 7, 26, 12, 18, 6, 11, 5, 10, 9);

int lowest_bit(uint mask) {
    uint lsb = mask & (~mask + 1u);
    return DEBRUIJN_BIT[(lsb * 0x077CB531u) >> 27];
}

#endif
