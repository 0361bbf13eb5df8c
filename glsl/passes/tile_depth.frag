// Tile depth: the nearest and farthest covered view depth of each screen tile (0, 0 where
// the tile covers no surface, so no light reaches it), and the tile's depth mask: bit b
// set when one of its surfaces lies in slice b of that slab (lights/tiles.glsl,
// Harada et al. 2012's 2.5D culling).
#include "lights/tiles.glsl"

uniform sampler2D g_depth;
layout(location = 0) out vec2 bounds;
layout(location = 1) out uint depth_mask;

void main() {
    ivec2 last = textureSize(g_depth, 0) - 1;
    ivec2 origin = ivec2(gl_FragCoord.xy) * TILE_SIZE;
    // One read of each pixel, kept in registers for the second sweep: the loops have
    // constant trip counts, so the array's indices are constants once unrolled. A tile
    // past the image's edge reads its last column or row again (a repeat changes neither
    // the bounds nor the mask).
    float z[TILE_SIZE * TILE_SIZE];
    float z_min = 3.0e38;
    float z_max = 0.0;
    for (int y = 0; y < TILE_SIZE; ++y) {
        for (int x = 0; x < TILE_SIZE; ++x) {
            float d = texelFetch(g_depth, min(origin + ivec2(x, y), last), 0).r;
            z[y * TILE_SIZE + x] = d;
            if (d > 0.0) {
                z_min = min(z_min, d);
                z_max = max(z_max, d);
            }
        }
    }
    uint bins = 0u;
    float scale = depth_bin_scale(z_min, z_max);
    for (int i = 0; i < TILE_SIZE * TILE_SIZE; ++i) {
        if (z[i] > 0.0) bins |= 1u << uint(depth_bin(z[i], z_min, scale));
    }
    bounds = z_max > 0.0 ? vec2(z_min, z_max) : vec2(0.0);
    depth_mask = z_max > 0.0 ? bins : 0u;
}
