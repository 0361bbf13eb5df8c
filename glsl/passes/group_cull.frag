// Coarse light culling: fragment (group.x * u_quads + k, group.y) writes the bitmasks of
// local lights 128 k ... 128 k + 127 whose range sphere reaches the frustum of a group of
// GROUP_TILES x GROUP_TILES tiles over the depth slab of its surfaces (the view-space box
// and the four side planes, lights/tiles.glsl). Every light that reaches one of the
// group's tiles passes, so light_cull.frag tests only these (Olsson & Assarsson 2011,
// "Tiled Shading", build the tile lists hierarchically the same way).
#include "lights/tiles.glsl"

uniform sampler2D u_tile_depth;      // RG32F per tile: view depth min, max (0 = empty)
uniform sampler2D u_local_lights;    // RGBA32F, 1024 per row: view-space centre, range
uniform int u_local_count;
uniform int u_quads;
uniform ivec2 u_tiles;
uniform ivec2 u_image_size;
uniform vec2 u_tan_half_fov;

out uvec4 mask;

// Radii grow by this fraction: the group's box and planes contain each tile's, but the
// float32 rounding of the two tests differs.
const float GROUP_MARGIN = 1e-4;

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    ivec2 group = ivec2(cell.x / u_quads, cell.y);
    int first = (cell.x - group.x * u_quads) * 128;
    ivec2 t0 = group * GROUP_TILES;
    float z_min = 3.0e38;
    float z_max = 0.0;
    for (int dy = 0; dy < GROUP_TILES; ++dy) {      // constant trip counts: unrolled
        for (int dx = 0; dx < GROUP_TILES; ++dx) {
            ivec2 t = min(t0 + ivec2(dx, dy), u_tiles - 1);  // clamped: a repeat is harmless
            vec2 z = texelFetch(u_tile_depth, t, 0).rg;
            if (z.y > 0.0) {
                z_min = min(z_min, z.x);
                z_max = max(z_max, z.y);
            }
        }
    }
    uvec4 reach = uvec4(0u);
    if (z_max > 0.0) {
        vec2 px_min = vec2(t0 * TILE_SIZE);
        vec2 px_max = min(vec2((t0 + GROUP_TILES) * TILE_SIZE), vec2(u_image_size));
        vec2 ndc_min = px_min / vec2(u_image_size) * 2.0 - 1.0;
        vec2 ndc_max = px_max / vec2(u_image_size) * 2.0 - 1.0;
        // The tiles' boxes reach Z_SLACK * z_max beyond their slices (tiles.glsl). The
        // group's planes and box, computed once for all its lights.
        TileFrustum f = tile_frustum(ndc_min, ndc_max, u_tan_half_fov, z_min, z_max, 0u);
        vec3 lo, hi;
        tile_box(f, z_min - f.slack, z_max + f.slack, lo, hi);
        int count = min(128, u_local_count - first);   // >= 1: the culler has no empty quad
        int b = 0;
        do {  // bottom-tested (passes/lighting.frag says why)
            int i = first + b;
            vec4 light = texelFetch(u_local_lights, ivec2(i % 1024, i / 1024), 0);
            float r = light.w * (1.0 + GROUP_MARGIN);
            if (box_reach(lo, hi, light.xyz, r) && tile_planes_reach(f, light.xyz, r)) {
                reach |= quad_bit(b >> 5, b & 31);
            }
        } while (++b < count);
    }
    mask = reach;
}
