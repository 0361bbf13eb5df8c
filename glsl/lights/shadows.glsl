// Shadow maps (RTR4 sec. 7.4): the visibility of a shadowed light at a shaded point, read
// from its depth map in one shared atlas (app/render/shadows.py renders them).
// Twin: the float64 ray-caster's shadow rays (app/reference/raycast.py light_visibility)
// are the reference it is measured against (docs/shadows.md), not an equal of the filter.
#ifndef PBS_SHADOWS_GLSL
#define PBS_SHADOWS_GLSL

// SHADOWS: the number of shadow maps; 0 (or undefined) compiles all of this out.
#ifndef SHADOWS
#define SHADOWS 0
#endif

#if SHADOWS
uniform sampler2D u_shadow_atlas;            // DEPTH24, the maps packed in rows; no compare mode
uniform int u_shadow_light[SHADOWS];         // the light (index into u_lights) of map k
uniform mat4 u_shadow_matrix[SHADOWS];       // world -> map k's clip space
// Map k: x, y its first texel in the atlas, z its size in texels, w 1 for PCF, 0 for none.
uniform vec4 u_shadow_rect[SHADOWS];
// Map k: x the normal offset in metres (directional) or in metres per metre of distance
// from the light (spot, cube face: a texel grows with distance), y 0 for an orthographic
// map, 1 for a spot's, 2 for a point light's cube face (six in a row: +x -x +y -y +z -z).
uniform vec2 u_shadow_offset[SHADOWS];

// 1 where the receiver's window depth z is not behind the occluder depth in texel t.
float shadow_test(ivec2 t, float z) {
    return z <= texelFetch(u_shadow_atlas, t, 0).r ? 1.0 : 0.0;
}

// Visibility through map k of the point p with normal n.
// Normal offset: p moves along n by a fixed number of shadow texels, so a surface tilted
// away from the light does not shadow itself between texel centres (acne); the shadow
// pass adds the slope-scaled depth offset (glPolygonOffset), docs/shadows.md.
float shadow_map_visibility(int k, vec3 p, vec3 n) {
    vec4 clip = u_shadow_matrix[k] * vec4(p, 1.0);
    float scale = u_shadow_offset[k].y > 0.5 ? clip.w : 1.0;
    clip = u_shadow_matrix[k] * vec4(p + n * (u_shadow_offset[k].x * scale), 1.0);
    if (clip.w <= 0.0) return 1.0;               // behind a spot: no cone there
    vec3 ndc = clip.xyz / clip.w;
    // Outside the map: lit. A cube face was chosen to hold p, so a point that its normal
    // offset moves just past the face's edge keeps the edge texels (the clamp below).
    bvec3 outside = greaterThan(abs(ndc), vec3(1.0));
    if (outside.z || (u_shadow_offset[k].y < 1.5 && any(outside.xy))) return 1.0;
    float z = ndc.z * 0.5 + 0.5;                 // window depth, glDepthRange(0, 1)
    vec4 rect = u_shadow_rect[k];
    // Texel coordinates within the map, the atlas offset added as an integer: float32
    // resolves a position of 2048 to 1.2e-4 texel, one of 4096 (a second map) to 2.4e-4.
    vec2 pos = (ndc.xy * 0.5 + 0.5) * rect.z;
    ivec2 lo = ivec2(rect.xy);
    ivec2 hi = lo + ivec2(rect.z) - 1;
    if (rect.w < 0.5) return shadow_test(clamp(lo + ivec2(floor(pos)), lo, hi), z);
    // PCF: a 3 x 3 box of bilinear comparisons one texel apart, which sums to 4 x 4 texels
    // with separable weights ((1 - f), 1, 1, f) / 3 around the texel below pos - 0.5.
    vec2 q = pos - 0.5;
    vec2 cell = floor(q);
    vec2 f = q - cell;
    ivec2 base = lo + ivec2(cell);
    float wx[4] = float[4](1.0 - f.x, 1.0, 1.0, f.x);
    float wy[4] = float[4](1.0 - f.y, 1.0, 1.0, f.y);
    float sum = 0.0;
    for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
            ivec2 t = clamp(base + ivec2(i - 1, j - 1), lo, hi);
            sum += wx[i] * wy[j] * shadow_test(t, z);
        }
    }
    return sum / 9.0;
}

// Visibility of light i at p, l the unit direction from p to the light: its map's, for a
// point light the cube face along the major axis of -l; 1 for a light without a map.
float shadow_visibility(int i, vec3 p, vec3 n, vec3 l) {
    for (int k = 0; k < SHADOWS; ++k) {
        if (u_shadow_light[k] != i) continue;
        int map = k;
        if (u_shadow_offset[k].y > 1.5) {        // faces k .. k + 5
            vec3 a = abs(l);
            int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
            map += 2 * axis + (-l[axis] < 0.0 ? 1 : 0);
        }
        return shadow_map_visibility(map, p, n);
    }
    return 1.0;
}
#endif

#endif
