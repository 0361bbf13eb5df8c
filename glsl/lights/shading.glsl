// A surface's outgoing radiance, in one place for the lighting pass (a G-buffer pixel) and
// the forward pass (a blended part's fragment, passes/forward.frag with ALPHA_BLEND):
//   L_o(v) = pi sum_i f(l_i, v) V_i(p) c_light_i (n.l_i)+      (RTR4 sec. 9.4; V_i: shadows)
//          + ao L_env(v)                                         (image-based light)
//          + L_e                                                 (emission)
// Each term is one line of surface_radiance; a new term is one more line there.
// Twin: app/reference/illumination.py (illumination_sum) and app/reference/ibl.py.
#ifndef PBS_LIGHTS_SHADING_GLSL
#define PBS_LIGHTS_SHADING_GLSL

#include "common/constants.glsl"
#include "lights/illumination.glsl"
#include "lights/ibl.glsl"

uniform sampler2D u_lights;     // RGBA32F, 3 texels per light, one light per row
uniform int u_light_count;
#if TILED_LIGHTS
uniform usampler2D u_tile_masks;   // RGBA32UI: TILE_QUADS texels per tile (app/render/culling.py)
uniform int u_first_local;         // lights [0, u_first_local) are directional
// DIRECTIONAL_LIGHTS: 1 when u_first_local > 0 (app/render/lighting.py).
#endif
#if GBUFFER_EMISSION
// Lights [x, y) are the environment's directions (app/frame/lights.py): the only light
// the occlusion map darkens (glTF 2.0: occlusion applies to indirect light). They are
// directional, so the tiled path meets them in its directional loop only.
uniform ivec2 u_environment_lights;
#define OCCLUSION(i) ((i) >= u_environment_lights.x && (i) < u_environment_lights.y ? ao : 1.0)
#define AMBIENT_OCCLUSION ao
#else
#define OCCLUSION(i) 1.0
#define AMBIENT_OCCLUSION 1.0
#endif

// sum_i f(l_i, v) V_i c_light_i (n.l_i)+ over the frame's lights, in ascending light
// order; with TILED_LIGHTS the local lights of screen tile `tile` only. ao: the occlusion
// map's value (the environment's directional lights only).
vec3 sum_lights(ivec2 tile, float ao, Surface s, ModelParams params, vec3 n, vec3 nc, vec3 t,
                vec3 p, vec3 v) {
    vec3 Lo = vec3(0.0);
#if TILED_LIGHTS
    // Directional lights reach everything; local lights only where their tile's mask
    // says so, visited in ascending order like the plain loop below. Bottom-tested loops,
    // and a scene without directional lights compiles theirs out (lights/illumination.glsl
    // says why).
#if DIRECTIONAL_LIGHTS
    int i = 0;
    do {
        Lo += OCCLUSION(i) * light_contribution(u_lights, i, s, params, n, nc, t, p, v);
    } while (++i < u_first_local);
#endif
    Lo = add_masked_lights(Lo, u_tile_masks, tile, u_lights, u_first_local, true, s, params,
                           n, nc, t, p, v);   // the masks hold local lights only
#else
    int i = 0;
    if (u_light_count > 0) do {  // bottom-tested, as the tiled loop above
        Lo += OCCLUSION(i) * light_contribution(u_lights, i, s, params, n, nc, t, p, v);
    } while (++i < u_light_count);
#endif
    return Lo;
}

// L_o(v) of the surface at p: the lights' sum, then the environment's light, then the
// emission (emission.rgb; emission.a is the occlusion map's ao), each compiled in only
// where the frame has it, so that a scene without one compiles as before it existed.
vec3 surface_radiance(ivec2 tile, vec4 emission, Surface s, ModelParams params, vec3 n,
                      vec3 nc, vec3 t, vec3 p, vec3 v) {
    float ao = emission.a;
    vec3 L = PI * sum_lights(tile, ao, s, params, n, nc, t, p, v);
#if ENVIRONMENT_IBL
    // The split sum (lights/ibl.glsl), once per point; the occlusion map darkens it.
    L += AMBIENT_OCCLUSION * ibl_radiance(s, n, t, v);
#endif
#if GBUFFER_EMISSION
    L += emission.rgb;   // emitted radiance, after the sum (RTR4 sec. 9.4's L_o plus L_e)
#endif
    return L;
}

#endif
