// Lighting pass: the seed's illumination sum over a G-buffer, in linear HDR.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (seed section 4)
#include "common/constants.glsl"
#include "common/encoding.glsl"
#include "common/position.glsl"
#include "brdf/model.glsl"
#include "brdf/fresnel.glsl"
#include "brdf/ndf.glsl"
#include "brdf/masking.glsl"
#include "brdf/diffuse.glsl"
#include "brdf/multiscatter.glsl"
#include "brdf/specular.glsl"
#include "brdf/material.glsl"
#include "lights/punctual.glsl"
#include "lights/tiles.glsl"

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

// f(l, v) c_light (n.l)+ of light i at p.
vec3 light_contribution(int i, Surface s, ModelParams params, vec3 n, vec3 t, vec3 p, vec3 v) {
    vec3 l;
    vec3 c_light = light_at(fetch_light(u_lights, i), p, l);
    float NoL = dot(n, l);
    if (NoL <= 0.0) return vec3(0.0);          // (n.l)+ : lights behind the surface add nothing
    return brdf_eval(s, params, n, t, l, v) * c_light * NoL;
}

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
    // says so, visited in ascending order like the plain loop below.
    //
    // Every loop here is bottom-tested. A SIMD rasteriser such as llvmpipe runs a loop's
    // body, masked, until every lane has left, and a top-tested loop ends with one more
    // pass over the whole body with every lane masked off: one wasted light evaluation per
    // pixel, 4 % of this pass at 256 lights. No `if` skips work on llvmpipe either (the
    // next word is chosen by selects, not fetched; a scene without directional lights
    // compiles their loop out): docs/performance.md.
#if DIRECTIONAL_LIGHTS
    int i = 0;
    do {
        Lo += light_contribution(i, s, params, n, t, p, v);
    } while (++i < u_first_local);
#endif
    ivec2 tile = px / TILE_SIZE;
    int chunk = 0;
    do {  // chunks of 1024 local lights: one for up to 1024 lights
        TileMask mask = load_tile_mask(u_tile_masks, tile, chunk);
        uint words = tile_occupancy(mask);   // the chunk's words that hold a light
        int w = 0;
        uint bits = 0u;
        if (words != 0u) {
            w = lowest_bit(words);
            words &= words - 1u;
            bits = tile_word(mask, w);
        }
        int base = u_first_local + 1024 * chunk;
        if (bits != 0u) do {
            int b = lowest_bit(bits);
            bits &= bits - 1u;                // clear that bit
            Lo += light_contribution(base + 32 * w + b, s, params, n, t, p, v);
            if (bits == 0u && words != 0u) {  // on to the next word that holds a light
                w = lowest_bit(words);
                words &= words - 1u;
                bits = tile_word(mask, w);
            }
        } while (bits != 0u);
    } while (++chunk * 8 < TILE_QUADS);
#else
    int i = 0;
    if (u_light_count > 0) do {  // bottom-tested, as the tiled loop above
        Lo += light_contribution(i, s, params, n, t, p, v);
    } while (++i < u_light_count);
#endif
    frag_color = vec4(PI * Lo, 1.0);
}
