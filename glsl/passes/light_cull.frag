// Light culling: fragment (tile.x * u_quads + k, tile.y) writes the bitmasks of local
// lights 128 k ... 128 k + 127 (four 32-bit words) whose range sphere (and spot cone)
// reaches the tile's surfaces. Only the lights of the tile's group mask (group_cull.frag)
// are tested.
#include "lights/tiles.glsl"

uniform sampler2D u_tile_depth;      // RG32F per tile: view depth min, max (0 = empty)
uniform usampler2D u_tile_bins;      // R32UI per tile: depth mask (lights/tiles.glsl)
uniform usampler2D u_group_masks;    // RGBA32UI per (group, quad): group_cull.frag
uniform usampler2D u_spot_bits;      // RGBA32UI per quad: the bits of its spot lights
uniform sampler2D u_local_lights;    // RGBA32F, 1024 per row: view-space centre, range
uniform sampler2D u_local_spots;     // RGBA32F, same layout: view-space axis, cos outer
                                     // (-2 for point lights)
uniform int u_quads;
uniform ivec2 u_image_size;
uniform vec2 u_tan_half_fov;

out uvec4 mask;

ivec2 light_texel(int i) {
    return ivec2(i % 1024, i / 1024);
}

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    ivec2 tile = ivec2(cell.x / u_quads, cell.y);
    int quad = cell.x - tile.x * u_quads;
    int first = quad * 128;
    vec2 z = texelFetch(u_tile_depth, tile, 0).rg;
    uvec4 reach = uvec4(0u);
    if (z.y > 0.0) {
        uint depth_mask = texelFetch(u_tile_bins, tile, 0).r;
        vec2 px_min = vec2(tile * TILE_SIZE);
        vec2 px_max = min(vec2((tile + 1) * TILE_SIZE), vec2(u_image_size));
        vec2 ndc_min = px_min / vec2(u_image_size) * 2.0 - 1.0;
        vec2 ndc_max = px_max / vec2(u_image_size) * 2.0 - 1.0;
        TileFrustum f = tile_frustum(ndc_min, ndc_max, u_tan_half_fov, z.x, z.y, depth_mask);
        // Bottom-tested loops over set bits (passes/lighting.frag says why): first the
        // sphere stage for each light of the group's mask, then the cone stage, a loop
        // over depth slices, for the spot lights that passed it only. Inside the first
        // loop the cone stage cost llvmpipe a masked slice test per light and tile
        // (measured in docs/performance.md).
        uvec4 group_mask = texelFetch(u_group_masks,
                                      ivec2((tile.x / GROUP_TILES) * u_quads + quad,
                                            tile.y / GROUP_TILES), 0);
        uint words = quad_occupancy(group_mask);
        int w = 0;
        uint bits = 0u;
        next_quad_word(group_mask, words, w, bits);
        if (bits != 0u) do {
            int k = lowest_bit(bits);
            bits &= bits - 1u;
            vec4 light = texelFetch(u_local_lights, light_texel(first + 32 * w + k), 0);
            if (sphere_reaches_tile(f, light.xyz, light.w) != 0u) reach |= quad_bit(w, k);
            if (bits == 0u) next_quad_word(group_mask, words, w, bits);
        } while (bits != 0u);

        // the spot lights whose sphere reaches the tile
        uvec4 cones = reach & texelFetch(u_spot_bits, ivec2(quad, 0), 0);
        words = quad_occupancy(cones);
        w = 0;
        bits = 0u;
        next_quad_word(cones, words, w, bits);
        if (bits != 0u) do {
            int k = lowest_bit(bits);
            bits &= bits - 1u;
            ivec2 texel = light_texel(first + 32 * w + k);
            vec4 light = texelFetch(u_local_lights, texel, 0);
            vec4 spot = texelFetch(u_local_spots, texel, 0);
            uint hits = sphere_slices(f, light.xyz, light.w);
            if (!cone_reaches_slices(f, light.xyz, light.w, spot, hits)) {
                reach &= ~quad_bit(w, k);
            }
            if (bits == 0u) next_quad_word(cones, words, w, bits);
        } while (bits != 0u);
    }
    mask = reach;
}
