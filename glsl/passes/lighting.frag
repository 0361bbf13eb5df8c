// Lighting pass: the illumination sum over a G-buffer, in linear HDR.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (RTR4 sec. 9.4)
#include "brdf/brdf.glsl"
#include "gbuffer/decode.glsl"
#include "lights/tiles.glsl"
#include "lights/illumination.glsl"
#include "lights/ibl.glsl"
#include "lights/environment_uniform.glsl"

uniform sampler2D u_materials;  // RGBA32F, MATERIAL_TEXELS per material (brdf/model.glsl)
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
    // Discards the background (and, with MODEL_GROUP, the other groups' pixels).
    GBufferPixel g = decode_gbuffer(gl_FragCoord.xy, u_materials, u_camera_pos,
                                    u_camera_to_world, u_tan_half_fov);
#if GBUFFER_EMISSION
    vec4 emission = decode_emission(gl_FragCoord.xy);
    float ao = emission.a;
#endif

    vec3 Lo = vec3(0.0);
#if TILED_LIGHTS
    // Directional lights reach everything; local lights only where their tile's mask
    // says so, visited in ascending order like the plain loop below. Bottom-tested loops,
    // and a scene without directional lights compiles theirs out (lights/illumination.glsl
    // says why).
#if DIRECTIONAL_LIGHTS
    int i = 0;
    do {
        Lo += light_contribution(u_lights, i, g.s, g.params, g.n, g.nc, g.t, g.p, g.v);
    } while (++i < u_first_local);
#endif
    Lo = add_masked_lights(Lo, u_tile_masks, px / TILE_SIZE, u_lights, u_first_local, g.s,
                           g.params, g.n, g.nc, g.t, g.p, g.v);
#else
    int i = 0;
    if (u_light_count > 0) do {  // bottom-tested, as the tiled loop above
        Lo += light_contribution(u_lights, i, g.s, g.params, g.n, g.nc, g.t, g.p, g.v);
    } while (++i < u_light_count);
#endif
#if ENVIRONMENT_IBL || ENVIRONMENT_UNIFORM
    // The environment's light, once per pixel: the split sum (lights/ibl.glsl) or the
    // uniform environment's quadrature (lights/environment_uniform.glsl); the occlusion
    // map darkens it (glTF 2.0: occlusion applies to indirect light).
#if ENVIRONMENT_IBL
    vec3 L_env = ibl_radiance(g.s, g.n, g.v);
#else
    vec3 L_env = uniform_environment_radiance(g.s, g.params, g.n, g.nc, g.t, g.v);
#endif
#if GBUFFER_EMISSION
    frag_color = vec4(PI * Lo + ao * L_env + emission.rgb, 1.0);
#else
    frag_color = vec4(PI * Lo + L_env, 1.0);
#endif
#elif GBUFFER_EMISSION
    // Emitted radiance, once per pixel, after the sum (RTR4 sec. 9.4's L_o plus L_e).
    frag_color = vec4(PI * Lo + emission.rgb, 1.0);
#else
    frag_color = vec4(PI * Lo, 1.0);
#endif
}
