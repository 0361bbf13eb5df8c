// Reading one pixel of the G-buffer (app/common/gbuffer.py GBUFFER_TARGETS) back as the ShadingPoint
// (brdf/material.glsl) light_contribution takes: the surface, its model's numbers, the
// shading frame, the view and the position.
// The lighting pass and the bench's floor pass both call decode_gbuffer, so both shade the
// very same values. Twin: app/reference/illumination.py decode_gbuffer.
#ifndef PBS_GBUFFER_DECODE_GLSL
#define PBS_GBUFFER_DECODE_GLSL

#include "common/encoding.glsl"
#include "common/position.glsl"
#include "brdf/model.glsl"
#include "brdf/material.glsl"

// uniform sampler2D g_<target>; of every target present (app/common/gbuffer.py GBUFFER_TARGETS)
GBUFFER_SAMPLERS
#ifdef GBUFFER_SAMPLES
// A multisampled G-buffer (render.antialiasing = "msaa", app/render/msaa.py): the sample
// every fetch below reads (GBUFFER_SAMPLE), set by the caller before each decode.
int gbuffer_sample = 0;
#endif

// RT0 and RT1 of pixel px as the G-buffer pass wrote them, before the unorm mapping and
// sanitising: (base colour, metallic) and (octahedral normal, perceptual roughness, F0).
// Under GBUFFER_CONSTANT_SURFACES the surface numbers are the texels of the pixel's
// material-table row (app/common/gbuffer.py GBUFFER_TARGETS): the same float32 numbers, 24 fewer bytes per
// pixel written and read. Twin: app/render/gbuffer.py GBuffer.read fills GBufferData alike
// (GBufferTarget.surface_texel).
void fetch_surface(ivec2 px, sampler2D materials, int material_id, out vec4 a, out vec4 b) {
#if GBUFFER_CONSTANT_SURFACES
    a = texelFetch(materials, ivec2(SURFACE_TEXEL, material_id), 0);
    b = vec4(texelFetch(g_normal, px, GBUFFER_SAMPLE).rg,
             texelFetch(materials, ivec2(SURFACE_TEXEL + 1, material_id), 0).rg);
#else
    a = texelFetch(g_base_color, px, GBUFFER_SAMPLE);
    b = texelFetch(g_normal, px, GBUFFER_SAMPLE);
#endif
}

// The pixel at window position frag_coord (gl_FragCoord.xy, the pixel centre), with the
// material table `materials` (brdf/model.glsl) and the camera. Discards the fragment, so
// that the cleared background stays, where nothing was drawn (or the depth is not finite);
// with MODEL_GROUP, also where the pixel's material belongs to another model group. Under
// UBER_MODELS it sets the model codes of the pixel's material. The point's nc is the
// decoded RT4 normal, sanitised (n where it was lost), or n itself without RT4.
ShadingPoint decode_gbuffer(vec2 frag_coord, sampler2D materials, vec3 camera_pos,
                            mat3 camera_to_world, vec2 tan_half_fov) {
    ivec2 px = ivec2(frag_coord);
    vec2 depth_id = texelFetch(g_depth, px, GBUFFER_SAMPLE).rg;
    float depth = depth_id.x;
    if (!(is_finite(depth) && depth > 0.0)) discard;
    int material_id = int(depth_id.y);
#if GBUFFER_TANGENT
    vec4 c = texelFetch(g_tangent, px, GBUFFER_SAMPLE);
#else
    vec4 c = vec4(0.0);   // no anisotropic material: anisotropy 0, the tangent unused
#endif
#ifdef MODEL_GROUP
    // Several models in the frame: this permutation shades only its own group's pixels.
    if (fetch_model_group(materials, material_id) != MODEL_GROUP) discard;
#endif
#if UBER_MODELS
    // One program for every material: the models become run-time branches on the codes
    // of this pixel's material (brdf/model.glsl).
    fetch_model_codes(materials, material_id);
#endif
    vec4 a, b;
    fetch_surface(px, materials, material_id, a, b);
#if GBUFFER_UNORM_DIRECTIONS
    // 16-bit unorm targets: the signed values back to [-1, 1] (common/encoding.glsl).
    b.rg = unorm_to_snorm(b.rg);
#if GBUFFER_TANGENT
    c.rgb = vec3(unorm_to_snorm(c.rg), unorm_to_snorm(c.b));
#endif
#endif
    // Textures can deliver NaN, Inf or out-of-range values; no pixel may turn them into
    // NaN radiance (docs/stability.md).
    Surface s = sanitize_surface(Surface(a.rgb, a.a, b.b, b.a, c.b));
    ModelParams params = fetch_model_params(materials, material_id);
    // RT6, RT8: the extension maps' factors on the row, each G-buffer factor target's
    // scale_by_<target> (brdf/material.glsl, generated from app/common/extension_maps.py)
    SCALE_BY_GBUFFER_FACTORS(params, px)
    vec3 t = oct_decode(c.rg);

    // World position from the depth buffer at the pixel centre.
    vec2 ndc_xy = (frag_coord / vec2(GBUFFER_SIZE(g_depth))) * 2.0 - 1.0;
    vec3 p = reconstruct_position(ndc_xy, depth, camera_pos, camera_to_world, tan_half_fov);
    vec3 v = normalize(camera_pos - p);
    vec3 n = sanitize_direction(oct_decode(b.rg), v);
#if GBUFFER_COAT_NORMAL
    vec2 e_coat = texelFetch(g_coat_normal, px, GBUFFER_SAMPLE).rg;
#if GBUFFER_UNORM_DIRECTIONS
    e_coat = unorm_to_snorm(e_coat);
#endif
    vec3 nc = sanitize_direction(oct_decode(e_coat), n);
#else
    vec3 nc = n;   // no coat has a normal of its own: the coat shades with n
#endif
    return ShadingPoint(s, params, n, nc, t, v, p);
}

#if SHADOWS
// The step in view space from pixel px (view depth z) to its neighbour q = px +- one pixel
// along an axis (view depth zq), written as dz (zq - z, or z - zq for the one before) times
// q's ray plus z times the rays' difference, so that float32 keeps it to a few ulp of the
// step rather than of the points (common/position.glsl's ray before the camera's rotation).
vec3 view_step(ivec2 q, float dz, float z, vec2 axis_step, vec2 size, vec2 tan_half_fov) {
    vec2 ndc = (vec2(q) + 0.5) / size * 2.0 - 1.0;
    return vec3((dz * ndc + z * axis_step) * tan_half_fov, -dz);
}

// The geometric normal at pixel px (view depth z), the shadow lookup's offset direction
// (lights/shadows.glsl): the G-buffer's normal is the normal-mapped one, which on a
// strong map over a coarse fold (ToyCar's cloth) can tilt below the triangle the shadow
// map holds, so that an offset along it moves into the surface, which shadows itself in
// specks. The plane through the view-space points of px and, per image axis, the
// neighbour nearer in depth (the background and pixels outside the image are not taken, a
// tie takes +x, +y), facing the viewer v; n where an axis has no neighbour, or where its
// two neighbours' depth steps differ by more than a factor 3 and 1e-4 z (a depth edge
// beside px: a silhouette, a one-pixel sliver, whose plane the depths do not tell). Twin:
// app/reference/shadows.py face_normals.
vec3 face_normal(ivec2 px, float z, mat3 camera_to_world, vec2 tan_half_fov, vec3 v,
                 vec3 n) {
    ivec2 size = GBUFFER_SIZE(g_depth);
    vec3 e[2];
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 d = axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
        ivec2 a = min(px + d, size - 1);
        ivec2 b = max(px - d, ivec2(0));
        float za = texelFetch(g_depth, a, GBUFFER_SAMPLE).r;
        float zb = texelFetch(g_depth, b, GBUFFER_SAMPLE).r;
        bool ok_a = a != px && is_finite(za) && za > 0.0;
        bool ok_b = b != px && is_finite(zb) && zb > 0.0;
        if (!ok_a && !ok_b) return n;
        float da = abs(za - z), db = abs(z - zb);
        // both sides one plane (their steps within a factor 3, or both within 1e-4 z: the
        // two triangles' rounding of a depth that hardly changes along the axis), else a
        // depth edge is beside px, and which side is its own surface is a guess: n
        if (ok_a && ok_b && abs(da - db) > 0.5 * (da + db) + 1e-4 * z) return n;
        bool take_a = ok_a && (!ok_b || da <= db);
        vec2 axis_step = 2.0 * vec2(d) / vec2(size);
        e[axis] = take_a ? view_step(a, za - z, z, axis_step, vec2(size), tan_half_fov)
                         : view_step(b, z - zb, z, axis_step, vec2(size), tan_half_fov);
    }
    vec3 g = cross(camera_to_world * e[0], camera_to_world * e[1]);
    float len = length(g);
    if (!(len > 0.0 && is_finite(len))) return n;
    g /= len;
    return dot(g, v) < 0.0 ? -g : g;
}
#endif

#if GBUFFER_EMISSION
// RT5 at window position frag_coord: emitted radiance (rgb) and the occlusion factor of
// environment light (a). Twin: app/reference/illumination.py decode_gbuffer.
vec4 decode_emission(vec2 frag_coord) {
    return texelFetch(g_emission, ivec2(frag_coord), GBUFFER_SAMPLE);
}
#endif

#endif
