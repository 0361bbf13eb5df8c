// Tile depth: the nearest and farthest covered view depth of each screen tile (0, 0 where
// the tile covers no surface, so no light reaches it), and the tile's depth mask: bit b
// set when one of its surfaces lies in slice b of that slab (lights/tiles.glsl,
// Harada et al. 2012's 2.5D culling).
#include "lights/tiles.glsl"

uniform sampler2D g_depth;
layout(location = 0) out vec2 bounds;
layout(location = 1) out uint depth_mask;

void main() {
    ivec2 size = textureSize(g_depth, 0);
    ivec2 origin = ivec2(gl_FragCoord.xy) * TILE_SIZE;
    ivec2 end = min(origin + TILE_SIZE, size);
    float z_min = 3.0e38;
    float z_max = 0.0;
    for (int y = origin.y; y < end.y; ++y) {
        for (int x = origin.x; x < end.x; ++x) {
            float z = texelFetch(g_depth, ivec2(x, y), 0).r;
            if (z > 0.0) {
                z_min = min(z_min, z);
                z_max = max(z_max, z);
            }
        }
    }
    uint bins = 0u;
    if (z_max > 0.0) {
        // Second sweep (the tile's depths are in cache now): the slices that hold a surface.
        float scale = depth_bin_scale(z_min, z_max);
        for (int y = origin.y; y < end.y; ++y) {
            for (int x = origin.x; x < end.x; ++x) {
                float z = texelFetch(g_depth, ivec2(x, y), 0).r;
                if (z > 0.0) bins |= 1u << uint(depth_bin(z, z_min, scale));
            }
        }
    }
    bounds = z_max > 0.0 ? vec2(z_min, z_max) : vec2(0.0);
    depth_mask = bins;
}
