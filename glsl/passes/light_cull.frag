// Light culling: fragment (tile.x * u_words + w, tile.y) writes the bitmask of local
// lights 32 w ... 32 w + 31 whose range sphere (and spot cone) reaches the tile's surfaces.
#include "lights/tiles.glsl"

uniform sampler2D u_tile_depth;      // RG32F per tile: view depth min, max (0 = empty)
uniform usampler2D u_tile_bins;      // R32UI per tile: depth mask (lights/tiles.glsl)
uniform sampler2D u_local_lights;    // RGBA32F, 1024 per row: view-space centre, range
uniform sampler2D u_local_spots;     // RGBA32F, same layout: view-space axis, cos outer
                                     // (-2 for point lights)
uniform int u_local_count;
uniform int u_words;
uniform ivec2 u_image_size;
uniform vec2 u_tan_half_fov;

out uint mask;

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    ivec2 tile = ivec2(cell.x / u_words, cell.y);
    int word = cell.x - tile.x * u_words;
    vec2 z = texelFetch(u_tile_depth, tile, 0).rg;
    uint bits = 0u;
    if (z.y > 0.0) {
        uint depth_mask = texelFetch(u_tile_bins, tile, 0).r;
        vec2 px_min = vec2(tile * TILE_SIZE);
        vec2 px_max = min(vec2((tile + 1) * TILE_SIZE), vec2(u_image_size));
        vec2 ndc_min = px_min / vec2(u_image_size) * 2.0 - 1.0;
        vec2 ndc_max = px_max / vec2(u_image_size) * 2.0 - 1.0;
        int first = word * 32;
        int count = min(32, u_local_count - first);
        for (int b = 0; b < count; ++b) {
            int i = first + b;
            ivec2 texel = ivec2(i % 1024, i / 1024);
            vec4 light = texelFetch(u_local_lights, texel, 0);
            vec4 spot = texelFetch(u_local_spots, texel, 0);
            if (light_reaches_tile(light.xyz, light.w, spot, ndc_min, ndc_max,
                                   u_tan_half_fov, z.x, z.y, depth_mask)) {
                bits |= 1u << uint(b);
            }
        }
    }
    mask = bits;
}
