// Tile depth bounds: the nearest and farthest covered view depth of each screen tile
// (0, 0 where the tile covers no surface, so no light reaches it).
#include "lights/tiles.glsl"

uniform sampler2D g_depth;
out vec2 bounds;

void main() {
    ivec2 size = textureSize(g_depth, 0);
    ivec2 origin = ivec2(gl_FragCoord.xy) * TILE_SIZE;
    float z_min = 3.0e38;
    float z_max = 0.0;
    for (int y = 0; y < TILE_SIZE; ++y) {
        for (int x = 0; x < TILE_SIZE; ++x) {
            ivec2 p = origin + ivec2(x, y);
            if (p.x >= size.x || p.y >= size.y) continue;
            float z = texelFetch(g_depth, p, 0).r;
            if (z > 0.0) {
                z_min = min(z_min, z);
                z_max = max(z_max, z);
            }
        }
    }
    bounds = z_max > 0.0 ? vec2(z_min, z_max) : vec2(0.0);
}
