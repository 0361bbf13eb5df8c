// Debug views: one quantity of the frame per pixel, as raw float32 values into an RGBA32F
// target (app/render/debug_views.py maps them to display bytes). DEBUG_VIEW is one of the
// DEBUG_* codes generated from app/common/debug_views.py. Every view writes
//   rgb: the quantity (a scalar repeated in r, g and b), a: 1 where it is defined;
// pixels no surface covers are discarded and keep the cleared (0, 0, 0, 0). The tiles view
// covers every pixel.
//
// The BRDF views (fresnel ... light) and f0 are compiled once per model group, as the
// lighting pass is (MODEL_GROUP discards the other groups' pixels), so each pixel shows the
// factors of its OWN model (f0: material_F0 with the group's SPECULAR_COLOR); they evaluate light u_light alone, with the lighting pass's functions:
// brdf_factors (brdf/material.glsl) for F, D, G2, f_spec, f_diffuse and
// light_contribution (lights/illumination.glsl) for the light view, so each shows what the
// sum L_o = pi sum_i f(l_i, v) c_light_i (n.l_i)+ (RTR4 sec. 9.4) is made of.
#ifndef DEBUG_VIEW
#define DEBUG_VIEW DEBUG_NORMAL   // compiles alone (tests/test_glsl_includes.py)
#endif
#include "brdf/brdf.glsl"
#include "gbuffer/decode.glsl"
#include "lights/illumination.glsl"

uniform sampler2D u_materials;  // RGBA32F, MATERIAL_TEXELS per material (app/common/material_fields.py)
uniform sampler2D u_lights;     // RGBA32F, 3 texels per light, one light per row
uniform int u_light;            // the light the BRDF views evaluate
#if DEBUG_VIEW == DEBUG_TILES && defined(TILE_QUADS)
uniform usampler2D u_tile_masks;   // RGBA32UI: TILE_QUADS texels per tile (app/render/culling.py)
#endif
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

out vec4 frag_color;

// The number of set bits of x (bitCount is GLSL 4.00): the classic SWAR sum of bit
// pairs, nibbles and bytes (Warren, "Hacker's Delight", sec. 5-1).
int popcount(uint x) {
    x = x - ((x >> 1) & 0x55555555u);
    x = (x & 0x33333333u) + ((x >> 2) & 0x33333333u);
    x = (x + (x >> 4)) & 0x0F0F0F0Fu;
    return int((x * 0x01010101u) >> 24);
}

void main() {
#if DEBUG_VIEW == DEBUG_TILES
    // Local lights in this pixel's 8x8 tile: the set bits of the culler's mask. Directional
    // lights reach every tile and are not in the masks, so they are not counted.
    int count = 0;
#ifdef TILE_QUADS
    ivec2 tile = ivec2(gl_FragCoord.xy) / TILE_SIZE;
    for (int k = 0; k < TILE_QUADS; ++k) {
        uvec4 q = texelFetch(u_tile_masks, ivec2(tile.x * TILE_QUADS + k, tile.y), 0);
        count += popcount(q.x) + popcount(q.y) + popcount(q.z) + popcount(q.w);
    }
#endif
    frag_color = vec4(vec3(float(count)), 1.0);
#else
    // Discards the background (and, with MODEL_GROUP, the other groups' pixels).
    ShadingPoint sp = decode_gbuffer(gl_FragCoord.xy, u_materials, u_camera_pos,
                                     u_camera_to_world, u_tan_half_fov);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 value = vec3(0.0);
    vec4 a, b;   // RT0 and RT1 as stored, before sanitising
    fetch_surface(px, u_materials, int(texelFetch(g_depth, px, 0).g), a, b);
#if DEBUG_VIEW == DEBUG_BASE_COLOR
    value = a.rgb;
#elif DEBUG_VIEW == DEBUG_NORMAL
    value = sp.n;                                       // the unit world normal shaded
#elif DEBUG_VIEW == DEBUG_ROUGHNESS
    value = vec3(b.b);                                  // perceptual roughness
#elif DEBUG_VIEW == DEBUG_METALLIC
    value = vec3(a.a);
#elif DEBUG_VIEW == DEBUG_F0
    value = material_F0(sp.s, sp.params);               // the RGB F0 the lights' Fresnel takes
#elif DEBUG_VIEW == DEBUG_DEPTH
    value = vec3(texelFetch(g_depth, px, 0).r);         // view depth, metres
#elif DEBUG_VIEW == DEBUG_MATERIAL_ID
    value = vec3(texelFetch(g_depth, px, 0).g);         // the material table's row
#elif DEBUG_VIEW == DEBUG_COAT_NORMAL
    value = sp.nc;                                      // the unit clear-coat normal shaded
#elif DEBUG_VIEW == DEBUG_EMISSION
#if GBUFFER_EMISSION
    value = decode_emission(gl_FragCoord.xy).rgb;       // emitted radiance (RT5)
#endif
#elif DEBUG_VIEW == DEBUG_OCCLUSION
#if GBUFFER_EMISSION
    value = vec3(decode_emission(gl_FragCoord.xy).a);   // factor on environment light
#else
    value = vec3(1.0);                                  // no occlusion map: 1
#endif
#elif DEBUG_VIEW == DEBUG_LIGHT
    // The very term the lighting pass adds for this light, times pi.
    value = PI * light_contribution(u_lights, u_light, sp, brdf_view(sp));
#else
    // F, D, G2, f_spec or f_diffuse of light u_light; 0 where the light is below the
    // surface, as brdf_eval returns there.
    vec3 l;
    light_at(fetch_light(u_lights, u_light), sp.position, l);
    if (dot(sp.n, l) > 0.0) {
        BrdfFactors b = brdf_factors(sp, l);
#if DEBUG_VIEW == DEBUG_FRESNEL
        value = b.F;
#elif DEBUG_VIEW == DEBUG_NDF
        value = vec3(b.D);
#elif DEBUG_VIEW == DEBUG_G2
        value = vec3(b.G2);
#elif DEBUG_VIEW == DEBUG_SPECULAR
        value = surface_reflection(b);   // the coat's lobe and the base's
#elif DEBUG_VIEW == DEBUG_DIFFUSE
        value = b.f_diffuse;
#endif
    }
#endif
    frag_color = vec4(value, 1.0);
#endif
}
