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
// SHADOW_COMPARE (no map of the frame uses PCSS, whose blocker search reads depths): the
// atlas has GL_COMPARE_REF_TO_TEXTURE (<=) and LINEAR filtering, so one texture() call is a
// bilinear 2 x 2 comparison (GL 4.5 core spec sec. 8.23, Texture Comparison Modes).
// Otherwise depths are read (texelFetch).
#if SHADOW_COMPARE
uniform sampler2DShadow u_shadow_atlas;      // DEPTH24, the maps packed in rows
#else
uniform sampler2D u_shadow_atlas;            // DEPTH24, the maps packed in rows; no compare mode
#endif
uniform int u_shadow_light[SHADOWS];         // the light (index into u_lights) of map k
uniform mat4 u_shadow_matrix[SHADOWS];       // world -> map k's clip space
// Map k: x, y its first texel in the atlas, z its size in texels, w 1 for PCF, 0 for none,
// 2 for PCSS.
uniform vec4 u_shadow_rect[SHADOWS];
// Map k: x the normal offset in metres (directional) or in metres per metre of distance
// from the light (spot, cube face: a texel grows with distance), y 0 for an orthographic
// map, 1 for a spot's, 2 for a point light's cube face (six in a row: +x -x +y -y +z -z),
// 3 for a directional light's cascade (orthographic; its cascades in a row, nearest first).
uniform vec2 u_shadow_offset[SHADOWS];

#if SHADOW_COMPARE
// The bilinear comparison at texel position x of the atlas (texel i's centre at i + 0.5):
// the four texels around x compared with z, weighted by x's fractions.
float shadow_compare(vec2 x, float z) {
    return texture(u_shadow_atlas, vec3(x / vec2(textureSize(u_shadow_atlas, 0)), z));
}

// 1 where the receiver's window depth z is not behind the occluder depth in texel t: the
// comparison at its centre, where the bilinear weights are (1, 0, 0, 0).
float shadow_test(ivec2 t, float z) {
    return shadow_compare(vec2(t) + 0.5, z);
}
#else
// 1 where the receiver's window depth z is not behind the occluder depth in texel t.
float shadow_test(ivec2 t, float z) {
    return z <= texelFetch(u_shadow_atlas, t, 0).r ? 1.0 : 0.0;
}
#endif

#if SHADOW_PCSS
// Map k's PCSS constants (app/render/shadows.py): x the light's size (radius in metres for
// a spot or cube face, tan of the angular radius for a directional light), y, z the
// perspective map's near and far planes (metres) or, for an orthographic map, 0 and its
// depth extent (metres), w a texel's size (metres per metre of distance along the axis;
// metres for an orthographic map).
uniform vec4 u_shadow_pcss[SHADOWS];

// Taps of the blocker search and of the variable PCF, and the widest either may reach
// (texels, radius): 16 and 32 nearest-texel taps of a Vogel disc, 32 texels.
const int PCSS_SEARCH_TAPS = 16;
const int PCSS_FILTER_TAPS = 32;
const float PCSS_MAX_RADIUS = 32.0;
const float GOLDEN_ANGLE = 2.39996323;

// Tap i of n on the unit disc, equal areas (Vogel 1979, "A better way to construct the
// sunflower head"): radius sqrt((i + 0.5) / n), angle i times the golden angle.
vec2 vogel_tap(int i, int n) {
    float r = sqrt((float(i) + 0.5) / float(n));
    float a = float(i) * GOLDEN_ANGLE;
    return r * vec2(cos(a), sin(a));
}

// The map's window depth z as metres from the light (perspective: view depth along the
// axis) or from the orthographic map's near plane.
float shadow_linear_depth(int k, float z) {
    vec4 c = u_shadow_pcss[k];
    if (u_shadow_offset[k].y < 0.5 || u_shadow_offset[k].y > 2.5) return z * c.z;
    return c.y * c.z / (c.z - z * (c.z - c.y));
}

// (texel position within map k, window depth) of the world point q.
vec3 shadow_map_coords(int k, vec3 q) {
    vec4 clip = u_shadow_matrix[k] * vec4(q, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    return vec3((ndc.xy * 0.5 + 0.5) * u_shadow_rect[k].z, ndc.z * 0.5 + 0.5);
}

// 1 where the receiver, the plane through (pos, z) with window-depth gradient g per texel,
// is not behind the occluder in texel t (lo: the map's first texel in the atlas).
// Receiver-plane depth bias (Isidoro 2006, "Shadow Mapping: GPU-based Tips and
// Techniques"): a wide kernel compares each texel with the receiver's own plane there,
// not with its depth at the centre, so a tilted receiver does not shadow itself.
float shadow_test_plane(ivec2 t, ivec2 lo, vec2 pos, float z, vec2 g) {
    vec2 centre = vec2(t - lo) + 0.5;
    return shadow_test(t, z + dot(g, centre - pos));
}

// PCSS (Fernando 2005, "Percentage-Closer Soft Shadows"): the mean depth of the blockers
// in a search disc, the penumbra's half width from it by similar triangles
//   w = (d_receiver - d_blocker) * light_size / d_blocker   (spot, cube face)
//   w = (d_receiver - d_blocker) * tan(angular radius)         (directional)
// and a percentage-closer filter over a disc of that radius. q: the point after its
// normal offset, n its normal; pos, z its texel position in map k and window depth.
float pcss_visibility(int k, vec3 q, vec3 n, vec2 pos, float z) {
    vec4 c = u_shadow_pcss[k];
    vec4 rect = u_shadow_rect[k];
    ivec2 lo = ivec2(rect.xy);
    ivec2 hi = lo + ivec2(rect.z) - 1;
    bool ortho = u_shadow_offset[k].y < 0.5 || u_shadow_offset[k].y > 2.5;
    float d_r = shadow_linear_depth(k, z);
    float texel = ortho ? c.w : c.w * d_r;   // metres a texel at the receiver
    // The receiver's plane in map space: two tangents of n, a texel long, projected.
    vec3 a = abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    vec3 t1 = normalize(cross(n, a));
    vec3 t2 = cross(n, t1);
    vec3 m1 = shadow_map_coords(k, q + t1 * texel) - vec3(pos, z);
    vec3 m2 = shadow_map_coords(k, q + t2 * texel) - vec3(pos, z);
    float det = m1.x * m2.y - m1.y * m2.x;
    vec2 g = vec2(0.0);
    if (abs(det) > 1e-6) {
        g = vec2(m2.y * m1.z - m1.y * m2.z, m1.x * m2.z - m2.x * m1.z) / det;
    }
    // Blocker search: every blocker that can hide part of the light lies within
    //   light_size (d_r - near) / (near d_r)   (perspective),  d_r tan(angle)  (ortho)
    // of the receiver's texel, capped at PCSS_MAX_RADIUS texels.
    float reach = ortho ? d_r * c.x / c.w : c.x * (d_r - c.y) / (c.y * d_r * c.w);
    float search = clamp(reach, 1.0, PCSS_MAX_RADIUS);
    float blockers = 0.0;
    float d_sum = 0.0;
    for (int i = 0; i < PCSS_SEARCH_TAPS; ++i) {
        ivec2 t = clamp(lo + ivec2(floor(pos + search * vogel_tap(i, PCSS_SEARCH_TAPS))), lo, hi);
        float depth = texelFetch(u_shadow_atlas, t, 0).r;
        vec2 centre = vec2(t - lo) + 0.5;
        if (depth < z + dot(g, centre - pos)) {
            blockers += 1.0;
            d_sum += shadow_linear_depth(k, depth);
        }
    }
    if (blockers == 0.0) return 1.0;
    float d_b = d_sum / blockers;
    float w = ortho ? (d_r - d_b) * c.x : (d_r - d_b) * c.x / d_b;   // metres
    float radius = clamp(w / texel, 1.0, PCSS_MAX_RADIUS);
    // Variable PCF: bilinear comparisons at the disc's taps.
    float sum = 0.0;
    for (int i = 0; i < PCSS_FILTER_TAPS; ++i) {
        vec2 s = pos + radius * vogel_tap(i, PCSS_FILTER_TAPS) - 0.5;
        vec2 cell = floor(s);
        vec2 f = s - cell;
        ivec2 b = lo + ivec2(cell);
        float v00 = shadow_test_plane(clamp(b, lo, hi), lo, pos, z, g);
        float v10 = shadow_test_plane(clamp(b + ivec2(1, 0), lo, hi), lo, pos, z, g);
        float v01 = shadow_test_plane(clamp(b + ivec2(0, 1), lo, hi), lo, pos, z, g);
        float v11 = shadow_test_plane(clamp(b + ivec2(1, 1), lo, hi), lo, pos, z, g);
        sum += mix(mix(v00, v10, f.x), mix(v01, v11, f.x), f.y);
    }
    return sum / float(PCSS_FILTER_TAPS);
}
#endif

#if SHADOW_GLASS
// Glass (app/render/shadows.py, docs/shadows.md "Glass"): the glass target beside the
// atlas, rgb the product of the transmittances of the glass surfaces in front of the
// opaque depth, alpha the nearest glass window depth (1 where none).
uniform sampler2D u_shadow_glass;
// The transmittance the last shadow_map_visibility found at its point (1: no glass).
vec3 shadow_glass_tint = vec3(1.0);

// Texel t's transmittance for a receiver at window depth z: the product where the
// receiver lies behind the nearest glass, 1 in front of it (lit glass does not shadow
// itself: its lit face is the nearest glass, and its normal offset moves it forward).
vec3 glass_texel(ivec2 t, float z) {
    vec4 g = texelFetch(u_shadow_glass, t, 0);
    return z > g.a ? g.rgb : vec3(1.0);
}

// The transmittance at texel position pos of the map whose texels are lo .. hi: the four
// texels around pos, each tested against z, bilinearly weighted (a soft tinted edge).
vec3 glass_transmittance_at(ivec2 lo, ivec2 hi, vec2 pos, float z) {
    vec2 q = pos - 0.5;
    vec2 cell = floor(q);
    vec2 f = q - cell;
    ivec2 b = lo + ivec2(cell);
    vec3 t00 = glass_texel(clamp(b, lo, hi), z);
    vec3 t10 = glass_texel(clamp(b + ivec2(1, 0), lo, hi), z);
    vec3 t01 = glass_texel(clamp(b + ivec2(0, 1), lo, hi), z);
    vec3 t11 = glass_texel(clamp(b + ivec2(1, 1), lo, hi), z);
    return mix(mix(t00, t10, f.x), mix(t01, t11, f.x), f.y);
}
#define SHADOW_VISIBILITY vec3
#else
#define SHADOW_VISIBILITY float
#endif

// Visibility through map k (m, rect, off: its u_shadow_matrix, u_shadow_rect and
// u_shadow_offset, read by the caller) of the point p with normal n; filt its filter
// (u_shadow_rect's w: 0 none, 1 PCF, 2 PCSS) and ortho whether the map is orthographic
// (its clip w is exactly 1: no scale, no division), constants where the caller has them.
// Normal offset: p moves along n by a fixed number of shadow texels, so a surface tilted
// away from the light does not shadow itself between texel centres (acne); the shadow
// pass adds the slope-scaled depth offset (glPolygonOffset), docs/shadows.md. n is the
// geometric normal (the lighting pass's face_normal, gbuffer/decode.glsl), not the
// normal-mapped one, which tilts off the surface the map holds.
float shadow_map_visibility(int k, mat4 m, vec4 rect, vec2 off, int filt, bool ortho,
                            vec3 p, vec3 n) {
    // the distance scale of a perspective map: clip w of p alone, its matrix's last row
    float scale = 1.0;
    if (!ortho) scale = dot(vec4(m[0][3], m[1][3], m[2][3], m[3][3]), vec4(p, 1.0));
    vec4 clip = m * vec4(p + n * (off.x * scale), 1.0);
    if (!ortho && clip.w <= 0.0) return 1.0;     // behind a spot: no cone there
    vec3 ndc = ortho ? clip.xyz : clip.xyz / clip.w;
    // Outside the map: lit. A cube face was chosen to hold p, so a point that its normal
    // offset moves just past the face's edge keeps the edge texels (the clamp below).
    bvec3 outside = greaterThan(abs(ndc), vec3(1.0));
    if (outside.z || (off.y < 1.5 && any(outside.xy))) return 1.0;
    float z = ndc.z * 0.5 + 0.5;                 // window depth, glDepthRange(0, 1)
    // Texel coordinates within the map, the atlas offset added as an integer: float32
    // resolves a position of 2048 to 1.2e-4 texel, one of 4096 (a second map) to 2.4e-4.
    vec2 pos = (ndc.xy * 0.5 + 0.5) * rect.z;
    ivec2 lo = ivec2(rect.xy);
    ivec2 hi = lo + ivec2(rect.z) - 1;
#if SHADOW_GLASS
    shadow_glass_tint = glass_transmittance_at(lo, hi, pos, z);
#endif
    if (filt == 0) return shadow_test(clamp(lo + ivec2(floor(pos)), lo, hi), z);
#if SHADOW_PCSS
    if (filt == 2) return pcss_visibility(k, p + n * (off.x * scale), n, pos, z);
#endif
    // PCF: a 3 x 3 box of bilinear comparisons one texel apart, which sums to 4 x 4 texels
    // with separable weights ((1 - f), 1, 1, f) / 3 around the texel below pos - 0.5.
    vec2 q = pos - 0.5;
    vec2 cell = floor(q);
    vec2 f = q - cell;
    ivec2 base = lo + ivec2(cell);
#if SHADOW_COMPARE
    // The same weights in four bilinear comparisons (sampler2DShadow, 2 x 2 texels each):
    // per axis, texels (-1, 0) weigh (1 - f, 1): a comparison 1 / (2 - f) of the way from
    // -1 to 0, times 2 - f; texels (1, 2) weigh (1, f): f / (1 + f) of the way, times
    // 1 + f. A position clamped to the map's edge texel centres reads the edge texel
    // alone, as the texel clamp of the 16 reads does. The tap positions are float32
    // texture coordinates: a fraction rounds to ulp(position), 1.2e-4 texel below 2048
    // (docs/shadows.md, "The twin of the lookup").
    vec2 wa = 2.0 - f;
    vec2 wb = 1.0 + f;
    vec2 inv = 1.0 / vec2(textureSize(u_shadow_atlas, 0));   // texels -> coordinates
    vec2 xa = clamp(vec2(base) - 0.5 + 1.0 / wa, vec2(lo) + 0.5, vec2(hi) + 0.5) * inv;
    vec2 xb = clamp(vec2(base) + 1.5 + f / wb, vec2(lo) + 0.5, vec2(hi) + 0.5) * inv;
    float sum = wa.x * wa.y * texture(u_shadow_atlas, vec3(xa, z))
              + wb.x * wa.y * texture(u_shadow_atlas, vec3(xb.x, xa.y, z))
              + wa.x * wb.y * texture(u_shadow_atlas, vec3(xa.x, xb.y, z))
              + wb.x * wb.y * texture(u_shadow_atlas, vec3(xb, z));
    return sum / 9.0;
#else
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
#endif
}

#if SHADOW_CASCADES
// Whether p (moved by its normal offset) lies in cascade k's map, CASCADE_MARGIN texels
// inside its edges (so that the filter's taps stay in it), and within its depth.
const float CASCADE_MARGIN = 3.0;
bool in_cascade(int k, vec3 p, vec3 n) {
    vec4 clip = u_shadow_matrix[k] * vec4(p + n * u_shadow_offset[k].x, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    float edge = 1.0 - 2.0 * CASCADE_MARGIN / u_shadow_rect[k].z;
    return all(lessThanEqual(abs(ndc.xy), vec2(edge))) && abs(ndc.z) <= 1.0;
}
#endif

// SHADOW_LIGHTS: the number of lights with maps. Their visibilities are looked up once per
// shaded point, before the light loop (shadow_prepare), not inside it: llvmpipe skips no
// branch, so a lookup inside the loop ran, masked, for every light of the frame times every
// map (docs/shadows.md, "One lookup per shadowed light and point"). Shadowed light j: x
// its light index, y its first map.
uniform ivec2 u_shadowed[SHADOW_LIGHTS];
uniform vec3 u_shadow_position[SHADOW_LIGHTS];   // shadowed light j's position (point lights)
// shadow_prepare's visibilities at the point (with glass, SHADOW_GLASS: coloured, the map's
// visibility times the glass's transmittance)
SHADOW_VISIBILITY shadow_vis[SHADOW_LIGHTS];

// Map k + f's matrix and rectangle for a per-point face f (0..5) of a point light: selects
// over the six, so that every array index stays uniform (an index that differs between a
// SIMD rasteriser's lanes makes each read of the array a gather per lane).
mat4 face_matrix(int k, int f) {
    mat4 m = u_shadow_matrix[k];
    for (int c = 1; c < 6; ++c) m = f == c ? u_shadow_matrix[k + c] : m;
    return m;
}
vec4 face_rect(int k, int f) {
    vec4 r = u_shadow_rect[k];
    for (int c = 1; c < 6; ++c) r = f == c ? u_shadow_rect[k + c] : r;
    return r;
}

// The visibility of shadowed light j at p with normal n; proj and filt its first map's
// projection (u_shadow_offset's y) and filter, constants in shadow_prepare's unrolled
// steps (app/render/shadows.py SHADOW_PROJ_j, SHADOW_FILTER_j), so that each step compiles
// only its own kind of lookup. A point light reads the cube face along the major axis of
// the direction from the light to p (ties to x, then y); a cascaded light its first
// cascade that holds p (else its last).
float shadowed_light_visibility(int j, int proj, int filt, vec3 p, vec3 n) {
    int k = u_shadowed[j].y;
    vec2 off = u_shadow_offset[k];
#if SHADOW_CASCADES
    if (proj == 3) {                             // cascades: the first that holds p
        int i = u_shadowed[j].x;
        int map = k;
        for (int c = k; c < SHADOWS; ++c) {
            if (u_shadow_light[c] != i) break;
            map = c;
            if (in_cascade(c, p, n)) break;
        }
        return shadow_map_visibility(map, u_shadow_matrix[map], u_shadow_rect[map],
                                     u_shadow_offset[map], filt, true, p, n);
    }
#endif
    if (proj == 2) {                             // faces k .. k + 5: +x -x +y -y +z -z
        vec3 d = p - u_shadow_position[j];
        vec3 a = abs(d);
        int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
        int f = 2 * axis + (d[axis] < 0.0 ? 1 : 0);
        return shadow_map_visibility(k + f, face_matrix(k, f), face_rect(k, f), off, filt,
                                     false, p, n);
    }
    return shadow_map_visibility(k, u_shadow_matrix[k], u_shadow_rect[k], off, filt,
                                 proj == 0 || proj == 3, p, n);
}

// shadow_prepare's step for shadowed light j (a literal), with its constants.
#if SHADOW_GLASS
#define SHADOW_STEP(j) shadow_glass_tint = vec3(1.0); shadow_vis[j] = shadowed_light_visibility(j, SHADOW_PROJ_##j, SHADOW_FILTER_##j, p, n) * shadow_glass_tint;
#else
#define SHADOW_STEP(j) shadow_vis[j] = shadowed_light_visibility(j, SHADOW_PROJ_##j, SHADOW_FILTER_##j, p, n);
#endif

// Every shadowed light's visibility at p with normal n, into shadow_vis: the first
// SHADOW_UNROLLED lights in steps of their own (every array index a constant), any further
// ones in a loop that reads their projection and filter from the uniforms.
const int SHADOW_UNROLLED = 8;   // the steps below; app/render/shadows.py SHADOW_UNROLLED
void shadow_prepare(vec3 p, vec3 n) {
    SHADOW_STEP(0)
#if SHADOW_LIGHTS > 1
    SHADOW_STEP(1)
#endif
#if SHADOW_LIGHTS > 2
    SHADOW_STEP(2)
#endif
#if SHADOW_LIGHTS > 3
    SHADOW_STEP(3)
#endif
#if SHADOW_LIGHTS > 4
    SHADOW_STEP(4)
#endif
#if SHADOW_LIGHTS > 5
    SHADOW_STEP(5)
#endif
#if SHADOW_LIGHTS > 6
    SHADOW_STEP(6)
#endif
#if SHADOW_LIGHTS > 7
    SHADOW_STEP(7)
#endif
#if SHADOW_LIGHTS > 8
    for (int j = SHADOW_UNROLLED; j < SHADOW_LIGHTS; ++j) {
        int k = u_shadowed[j].y;
#if SHADOW_GLASS
        shadow_glass_tint = vec3(1.0);
#endif
        shadow_vis[j] = shadowed_light_visibility(j, int(u_shadow_offset[k].y),
                                                  int(u_shadow_rect[k].w), p, n)
#if SHADOW_GLASS
                        * shadow_glass_tint
#endif
                        ;
    }
#endif
}

// Visibility of light i at the point shadow_prepare was given: its map's, 1 for a light
// without one (selects over the shadowed lights, no indexed read).
SHADOW_VISIBILITY shadow_visibility(int i) {
    SHADOW_VISIBILITY v = SHADOW_VISIBILITY(1.0);
    for (int j = 0; j < SHADOW_LIGHTS; ++j) {
        v = u_shadowed[j].x == i ? shadow_vis[j] : v;
    }
    return v;
}
#endif

#endif
