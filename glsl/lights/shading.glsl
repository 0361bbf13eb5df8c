// A surface's outgoing radiance, in one place for the lighting pass (a G-buffer pixel) and
// the forward pass (a blended part's fragment, passes/forward.frag with ALPHA_BLEND):
//   L_o(v) = pi sum_i f(l_i, v) V_i(p) c_light_i (n.l_i)+      (RTR4 sec. 9.4; V_i: shadows)
//          + ao L_env(v)                   (image-based light or the uniform environment)
//          + L_e                                                 (emission)
// Each term is one line of surface_radiance; a new term is one more line there.
// Twin: app/reference/illumination.py (illumination_sum), app/reference/ibl.py and
// app/reference/environment_uniform.py.
#ifndef PBS_LIGHTS_SHADING_GLSL
#define PBS_LIGHTS_SHADING_GLSL

#include "common/constants.glsl"
#include "lights/illumination.glsl"
#include "lights/ibl.glsl"
#include "lights/environment_uniform.glsl"

uniform sampler2D u_lights;     // RGBA32F, 3 texels per light, one light per row
uniform int u_light_count;
#if TILED_LIGHTS
uniform usampler2D u_tile_masks;   // RGBA32UI: TILE_QUADS texels per tile (app/render/culling.py)
uniform int u_first_local;         // lights [0, u_first_local) are directional
// DIRECTIONAL_LIGHTS: 1 when u_first_local > 0 (app/render/lighting.py).
#endif
// The occlusion map darkens the environment's light only (glTF 2.0: occlusion applies to
// indirect light), never the punctual lights.
#if GBUFFER_EMISSION
#define AMBIENT_OCCLUSION ao
#else
#define AMBIENT_OCCLUSION 1.0
#endif

// sum_i f(l_i, v) V_i c_light_i (n.l_i)+ over the frame's lights, in ascending light
// order; with TILED_LIGHTS the local lights of screen tile `tile` only. ng: the unit
// geometric normal (no normal map), the direction of the shadow lookup's offset.
vec3 sum_lights(ivec2 tile, ShadingPoint sp, vec3 ng) {
    vec3 Lo = vec3(0.0);
    BrdfView bv = brdf_view(sp);   // the BRDF's factors of the point alone, once
#if SHADOWS
    shadow_prepare(sp.position, ng);   // every shadowed light's visibility, once
#endif
#if TILED_LIGHTS
    // Directional lights reach everything; local lights only where their tile's mask
    // says so, visited in ascending order like the plain loop below. Bottom-tested loops,
    // and a scene without directional lights compiles theirs out (lights/illumination.glsl
    // says why).
#if DIRECTIONAL_LIGHTS
    int i = 0;
    do {
        Lo += light_contribution(u_lights, i, sp, bv);
    } while (++i < u_first_local);
#endif
    // the masks hold local lights only
    Lo = add_masked_lights(Lo, u_tile_masks, tile, u_lights, u_first_local, true, sp, bv);
#else
    int i = 0;
    if (u_light_count > 0) do {  // bottom-tested, as the tiled loop above
        Lo += light_contribution(u_lights, i, sp, bv);
    } while (++i < u_light_count);
#endif
    return Lo;
}

// L_o(v) of the point sp: the lights' sum, then the environment's light, then the
// emission (emission.rgb; emission.a is the occlusion map's ao), each compiled in only
// where the frame has it, so that a scene without one compiles as before it existed.
// ng: the geometric normal, for the shadow lookup (sum_lights).
vec3 surface_radiance(ivec2 tile, vec4 emission, ShadingPoint sp, vec3 ng) {
    float ao = emission.a;
    vec3 L = PI * sum_lights(tile, sp, ng);
#if ENVIRONMENT_IBL
    // The split sum (lights/ibl.glsl), once per point; the occlusion map darkens it.
    L += AMBIENT_OCCLUSION * ibl_radiance(sp);
#elif ENVIRONMENT_UNIFORM
    // A uniform radiance's quadrature (lights/environment_uniform.glsl), once per point.
    L += AMBIENT_OCCLUSION * uniform_environment_radiance(sp);
#endif
#if GBUFFER_EMISSION
    L += emission.rgb;   // emitted radiance, after the sum (RTR4 sec. 9.4's L_o plus L_e)
#endif
    return L;
}

#endif
