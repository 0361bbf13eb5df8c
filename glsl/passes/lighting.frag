// Lighting pass: the seed's illumination sum over a G-buffer, in linear HDR.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (seed section 4)
#include "brdf/brdf.glsl"
#include "common/encoding.glsl"
#include "common/position.glsl"
#include "lights/tiles.glsl"
#include "lights/illumination.glsl"

uniform sampler2D g_albedo;
uniform sampler2D g_normal;
uniform sampler2D g_depth;
#ifndef GBUFFER_TANGENT
#define GBUFFER_TANGENT 1
#endif
#if GBUFFER_TANGENT
uniform sampler2D g_tangent;    // only where a material is anisotropic (docs/gbuffer.md)
#endif
uniform sampler2D u_materials;  // RGBA32F, 4 texels per material (brdf/model.glsl)
uniform sampler2D u_lights;     // RGBA32F, 3 texels per light, one light per row
uniform int u_light_count;
#if TILED_LIGHTS
uniform usampler2D u_tile_masks;   // RGBA32UI: TILE_QUADS texels per tile (app/render/culling.py)
uniform int u_first_local;         // lights [0, u_first_local) are directional
// DIRECTIONAL_LIGHTS: 1 when u_first_local > 0 (app/render/lighting.py).
#endif
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 depth_id = texelFetch(g_depth, px, 0).rg;
    float depth = depth_id.x;
    // Nothing drawn (or a non-finite depth): the cleared background stays.
    if (!(is_finite(depth) && depth > 0.0)) discard;
    int material_id = int(depth_id.y);
#if GBUFFER_TANGENT
    vec4 c = texelFetch(g_tangent, px, 0);
#else
    vec4 c = vec4(0.0);   // no anisotropic material: anisotropy 0, the tangent unused
#endif
#ifdef MODEL_GROUP
    // Several models in the frame: this permutation shades only its own group's pixels.
    if (fetch_model_group(u_materials, material_id) != MODEL_GROUP) discard;
#endif
#if UBER_MODELS
    // One program for every material: the models become run-time branches on the codes
    // of this pixel's material (brdf/model.glsl).
    fetch_model_codes(u_materials, material_id);
#endif
    vec4 a = texelFetch(g_albedo, px, 0);
    vec4 b = texelFetch(g_normal, px, 0);
    // Textures can deliver NaN, Inf or out-of-range values; no pixel may turn them into
    // NaN radiance (docs/stability.md).
    Surface s = sanitize_surface(Surface(a.rgb, a.a, b.b, b.a, c.b));
    ModelParams params = fetch_model_params(u_materials, material_id);
    vec3 t = oct_decode(c.rg);

    // World position from the depth buffer at the pixel centre.
    vec2 ndc_xy = (gl_FragCoord.xy / vec2(textureSize(g_depth, 0))) * 2.0 - 1.0;
    vec3 p = reconstruct_position(ndc_xy, depth, u_camera_pos, u_camera_to_world,
                                  u_tan_half_fov);
    vec3 v = normalize(u_camera_pos - p);
    vec3 n = sanitize_direction(oct_decode(b.rg), v);

    vec3 Lo = vec3(0.0);
#if TILED_LIGHTS
    // Directional lights reach everything; local lights only where their tile's mask
    // says so, visited in ascending order like the plain loop below. Bottom-tested loops,
    // and a scene without directional lights compiles theirs out (lights/illumination.glsl
    // says why).
#if DIRECTIONAL_LIGHTS
    int i = 0;
    do {
        Lo += light_contribution(u_lights, i, s, params, n, t, p, v);
    } while (++i < u_first_local);
#endif
    Lo = add_masked_lights(Lo, u_tile_masks, px / TILE_SIZE, u_lights, u_first_local, s,
                           params, n, t, p, v);
#else
    int i = 0;
    if (u_light_count > 0) do {  // bottom-tested, as the tiled loop above
        Lo += light_contribution(u_lights, i, s, params, n, t, p, v);
    } while (++i < u_light_count);
#endif
    frag_color = vec4(PI * Lo, 1.0);
}
