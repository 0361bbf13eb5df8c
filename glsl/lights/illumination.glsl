// The terms of the illumination sum L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+
// (RTR4 sec. 9.4; a wrapped model's term past the terminator, RTR4 sec. 9.10, below), shared by the lighting, floor and forward passes so that every
// variant the bench compares adds the same float32 terms in the same order.
// Twin: app/reference/illumination.py.
#ifndef PBS_ILLUMINATION_GLSL
#define PBS_ILLUMINATION_GLSL

#include "brdf/material.glsl"
#include "lights/punctual.glsl"
#include "lights/shadows.glsl"
#include "lights/area.glsl"
// For the masked loop only (TILE_QUADS), but included always: app/gl/shaders.py splices
// includes before the preprocessor runs, so one inside #ifdef would count as included
// even where the #ifdef drops it. Without TILE_QUADS it adds functions nothing calls.
#include "lights/tiles.glsl"

// Where light i is read. With LIGHT_UNIFORMS (the array's size in lights, set by
// app/render/lighting.py where the context's fragment uniform vectors hold them) the
// lighting pass keeps the three texels of every light in a uniform array, which the
// rasteriser reads faster than texel fetches (docs/performance.md measures both);
// otherwise, and in every other pass, from the light texture `lights`. The values are
// the same float32 texels either way, so the two forms give the same image.
#ifdef LIGHT_UNIFORMS
uniform vec4 u_light_vec[3 * LIGHT_UNIFORMS];
#endif
PunctualLight read_light(sampler2D lights, int i) {
#ifdef LIGHT_UNIFORMS
    return unpack_light(u_light_vec[3 * i], u_light_vec[3 * i + 1], u_light_vec[3 * i + 2]);
#else
    return fetch_light(lights, i);
#endif
}

// f(l, v) c_light (n.l)+ of a light that sends c_light along l (towards it) to the point
// sp (light i: its shadow map's index); sp.nc is the clear coat's normal (n where the coat
// has none of its own). With GBUFFER_COAT_NORMAL (a coat of the scene has a normal other
// than its base's: app/common/gbuffer.py GBUFFER_TARGETS) a coated material's layers take their own cosines
// (brdf_eval_layered_cos in brdf/material.glsl). bv: brdf_view(sp), computed once before
// the point's light loop (brdf/material.glsl says why), here and in the functions below.
vec3 light_term_at(vec3 c_light, vec3 l, int i, ShadingPoint sp, BrdfView bv) {
#if SHADOWS
    // a shadowed light (lights/shadows.glsl: looked up by shadow_prepare, before the loop)
    c_light *= shadow_visibility(i);
#endif
#if GBUFFER_COAT_NORMAL && CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE) {
        return brdf_eval_layered_cos(sp, l) * c_light;
    }
#endif
    float NoL = dot(sp.n, l);
#if UBER_MODELS || DIFFUSE_MODEL == DIFFUSE_CLOTH_EMPIRICAL
    // Wrap lighting (RTR4 sec. 9.10): a model that wants light past its terminator gets it.
    // The empirical cloth with wrap w > 0 takes f (n.l) from its wrapped lobes at and below
    // n.l = CLOTH_WRAP_MIN_N_DOT_L, down to -w (brdf/cloth.glsl); no other model does.
    if (DIFFUSE_MODEL == DIFFUSE_CLOTH_EMPIRICAL && sp.params.cloth_wrap > 0.0
            && NoL <= CLOTH_WRAP_MIN_N_DOT_L) {
        return cloth_wrapped_term(sp, NoL) * c_light;
    }
#endif
    if (NoL <= 0.0) return vec3(0.0);          // (n.l)+ : lights behind the surface add nothing
    return brdf_eval_view(sp, bv, l) * c_light * NoL;
}

// The term of `light` at sp, wherever the light was read from (light_contribution below:
// the light texture or the uniform array; the bench's limit pass: its own form).
vec3 light_term(PunctualLight light, int i, ShadingPoint sp, BrdfView bv) {
#if AREA_LIGHTS
    if (light.type >= LIGHT_RECT) return area_light_term(light, i, sp, bv);  // lights/area.glsl
#endif
    vec3 l;
    vec3 c_light = light_at(light, sp.position, l);
    return light_term_at(c_light, l, i, sp, bv);
}

// light_term of a light known to be a point or spot light (local_light_at): the same
// float32 operations for it, without the test for a directional light.
vec3 local_light_term(PunctualLight light, int i, ShadingPoint sp, BrdfView bv) {
#if AREA_LIGHTS
    if (light.type >= LIGHT_RECT) return area_light_term(light, i, sp, bv);  // lights/area.glsl
#endif
    vec3 l;
    vec3 c_light = local_light_at(light, sp.position, l);
    return light_term_at(c_light, l, i, sp, bv);
}

// light_term of light i of the light texture (or, with LIGHT_UNIFORMS, the uniform array).
vec3 light_contribution(sampler2D lights, int i, ShadingPoint sp, BrdfView bv) {
    return light_term(read_light(lights, i), i, sp, bv);
}

#ifdef TILE_QUADS
// Lo plus the terms of the set bits of cell `cell`'s light mask (lights/tiles.glsl:
// TILE_QUADS RGBA32UI texels per cell; bit k is light base + k), added one by one in
// ascending light order, so that a sum continued from other lights rounds exactly as the
// plain loop over all lights does. A cell is a screen tile for the lighting pass and a
// pixel for the bench's floor pass. local_only (a constant): every masked light is a
// point or spot light, so local_light_term serves (the lighting pass's tiles; the floor's
// pixels where the scene has no directional light).
//
// Every loop here is bottom-tested. A SIMD rasteriser such as llvmpipe runs a loop's
// body, masked, until every lane has left, and a top-tested loop ends with one more pass
// over the whole body with every lane masked off: one wasted light evaluation per pixel.
// No `if` skips work on llvmpipe either, so the next word is chosen by selects, not
// fetched (docs/performance.md measures both). Two nested loops, the words outside and
// a word's bits inside, so that the next word is looked up once per word, not tested for
// after every light: in a tile every pixel walks the same mask, so the lanes of a SIMD
// rasteriser leave both loops together (docs/performance.md, "The light
// loop", measures it against one flat loop).
vec3 add_masked_lights(vec3 Lo, usampler2D masks, ivec2 cell, sampler2D lights, int base,
                       bool local_only, ShadingPoint sp, BrdfView bv) {
    int chunk = 0;
    do {  // chunks of 1024 lights: one for up to 1024 lights
        TileMask mask = load_tile_mask(masks, cell, chunk);
        uint words = tile_occupancy(mask);   // the chunk's words that hold a light
        int w = 0;
        uint bits = 0u;
        next_tile_word(mask, words, w, bits);
        int first = base + 1024 * chunk;
        if (bits != 0u) do {
            int word_first = first + 32 * w;
            do {
                int b = lowest_bit(bits);
                bits &= bits - 1u;                // clear that bit
                int k = word_first + b;
                if (local_only) {  // a compile-time constant at every call
                    Lo += local_light_term(read_light(lights, k), k, sp, bv);
                } else {
                    Lo += light_contribution(lights, k, sp, bv);
                }
            } while (bits != 0u);
            next_tile_word(mask, words, w, bits);
        } while (bits != 0u);
    } while (++chunk * 8 < TILE_QUADS);
    return Lo;
}
#endif

#endif
