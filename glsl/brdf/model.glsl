// Which model each BRDF term uses, and the per-material numbers those models need
// (run-time, from the material table). The layout and the model names are defined once in
// app/common/models.py; the assembler (app/gl/shaders.py) generates their constants
// (FRESNEL_SCHLICK 0, NDF_GGX 0, ..., DIFFUSE_BURLEY_RENORMALIZED 7) at the top of every
// program, in the order of the Python tuples.
// A pass is compiled once per distinct model: FRESNEL_MODEL, NDF_MODEL, ... are #define'd
// integer constants, so the plain `if (NDF_MODEL == NDF_BECKMANN)` of each dispatch
// function (material.glsl, specular.glsl) is folded by the compiler and a scene pays only
// for the terms its materials select.
//
// UBER_MODELS 1 (the bench's `uber` variant, docs/performance.md "Specialization"): one
// program for every material. The same names then expand to globals that
// fetch_model_codes() sets per pixel from the material table, and the SAME dispatch code
// becomes run-time branches; every model function, the multiple-scattering table and the
// anisotropic tangent frame are compiled in.
#ifndef PBS_MODEL_GLSL
#define PBS_MODEL_GLSL

#ifndef UBER_MODELS
#define UBER_MODELS 0
#endif

#if UBER_MODELS
// Run-time model codes of the pixel being shaded (fetch_model_codes). A pass that also
// defines one of the compile-time names fails to compile (macro redefinition).
int uber_fresnel_model;
int uber_ndf_model;
int uber_lambda_form;
int uber_g2_model;
int uber_correlation;
int uber_diffuse_model;
int uber_multiscatter;
int uber_anisotropic;
int uber_fresnel_internal;
int uber_thin_film;  // thin film (RTR4 sec. 9.11)
int uber_sheen_model;  // sheen (RTR4 sec. 9.10)
int uber_clearcoat_model;  // clear coat (RTR4 sec. 9.12)
int uber_diffraction_model;  // diffraction grating (RTR4 sec. 9.11)
int uber_fiber_model;  // micro-cylinder fibres (RTR4 sec. 9.10)
#define FRESNEL_MODEL uber_fresnel_model
#define NDF_MODEL uber_ndf_model
#define LAMBDA_FORM uber_lambda_form
#define G2_MODEL uber_g2_model
#define CORRELATION uber_correlation
#define DIFFUSE_MODEL uber_diffuse_model
#define MULTISCATTER uber_multiscatter
#define ANISOTROPIC uber_anisotropic
#define FRESNEL_INTERNAL uber_fresnel_internal
#define THIN_FILM uber_thin_film  // thin film (RTR4 sec. 9.11)
#define SHEEN_MODEL uber_sheen_model
#define CLEARCOAT_MODEL uber_clearcoat_model
#define DIFFRACTION_MODEL uber_diffraction_model
#define FIBER_MODEL uber_fiber_model
#else
// The standard model unless a pass says otherwise.
#ifndef FRESNEL_MODEL
#define FRESNEL_MODEL FRESNEL_SCHLICK
#endif
#ifndef NDF_MODEL
#define NDF_MODEL NDF_GGX
#endif
#ifndef LAMBDA_FORM
#define LAMBDA_FORM LAMBDA_EXACT
#endif
#ifndef G2_MODEL
#define G2_MODEL G2_HEIGHT_CORRELATED
#endif
#ifndef CORRELATION
#define CORRELATION CORRELATION_EXP
#endif
#ifndef DIFFUSE_MODEL
#define DIFFUSE_MODEL DIFFUSE_LAMBERT
#endif
#ifndef MULTISCATTER
#define MULTISCATTER 0
#endif
#ifndef ANISOTROPIC
#define ANISOTROPIC 0
#endif
#ifndef FRESNEL_INTERNAL
#define FRESNEL_INTERNAL 0
#endif
// Thin film (RTR4 sec. 9.11): 1 where the material's F is a film's (brdf/thin_film.glsl).
#ifndef THIN_FILM
#define THIN_FILM 0
#endif
// sheen (RTR4 sec. 9.10): none unless a pass says otherwise (brdf/sheen.glsl)
#ifndef SHEEN_MODEL
#define SHEEN_MODEL SHEEN_NONE
#endif
// Clear coat (RTR4 sec. 9.12): none unless a pass says otherwise.
#ifndef CLEARCOAT_MODEL
#define CLEARCOAT_MODEL CLEARCOAT_NONE
#endif
// Diffraction grating (RTR4 sec. 9.11): none unless a pass says otherwise.
#ifndef DIFFRACTION_MODEL
#define DIFFRACTION_MODEL DIFFRACTION_NONE
#endif
// Micro-cylinder fibres (RTR4 sec. 9.10): none unless a pass says otherwise.
#ifndef FIBER_MODEL
#define FIBER_MODEL FIBER_NONE
#endif
#endif  // UBER_MODELS

// Whether the coat's code is compiled in (always under UBER_MODELS, where the model is a
// run-time branch): a material without a coat compiles exactly as it did before it existed.
#if UBER_MODELS || CLEARCOAT_MODEL != CLEARCOAT_NONE
#define CLEARCOAT_ON 1
#else
#define CLEARCOAT_ON 0
#endif

// SPECULAR_LAMBDA_G2 is false where the specular term has a fused visibility form
// V = G2/(4 n.l n.v) (the standard height-correlated GGX, or Hammon's approximation of it),
// true where it goes through the Smith Lambdas and the selected G2. A constant expression
// in a specialized pass, a per-pixel one under UBER_MODELS.
#define SPECULAR_FUSED_V (G2_MODEL == G2_HAMMON || (G2_MODEL == G2_HEIGHT_CORRELATED && \
                          NDF_MODEL == NDF_GGX && ANISOTROPIC == 0))
#define SPECULAR_LAMBDA_G2 (!SPECULAR_FUSED_V)

// Per-material numbers of the optional models; indices are relative to the medium
// the light arrives from.
struct ModelParams {
    vec3 f90;               // generalised Schlick: F at grazing
    float fresnel_exponent; // generalised Schlick: 1/p
    vec3 eta;               // conductor: n / n1 per channel
    float eta_dielectric;   // dielectric: n2 / n1
    vec3 k;                 // conductor: k / n1 per channel
    float gtr_gamma;        // GTR tail exponent
    // --- thin film (RTR4 sec. 9.11), texel 7 ---
    float film_thickness;   // nm
    float film_eta;         // film index / medium index
    float film_ior;         // film index (optical path)
    // sheen (RTR4 sec. 9.10), texel 6
    vec3 sheen_color;       // the cloth layer's colour; black: no layer
    float sheen_roughness;  // its perceptual roughness (alpha = r^2)
    // --- clear coat (RTR4 sec. 9.12), texels 4-5; zero without a coat ---
    vec3 clearcoat_color;       // transmittance at normal incidence through the coat, once
    float clearcoat;            // strength 0..1
    float clearcoat_roughness;  // perceptual
    float clearcoat_eta;        // coat index / medium index
    // --- diffraction grating (RTR4 sec. 9.11), texel 8; zero without one ---
    float grating_period;       // nm, the groove spacing
    float grating_depth;        // nm, peak-to-valley depth of the sinusoidal profile
    // --- empirical cloth (RTR4 sec. 9.10, DIFFUSE_CLOTH_EMPIRICAL), texels 9-11 ---
    vec4 cloth_rim_inner;       // (k_rim, a_rim, k_inner, a_inner)
    vec3 cloth_scatter;         // c_scatter
    float cloth_wrap;           // w
    vec3 cloth_sheen;           // k_sheen c_sheen
    float cloth_diffuse;        // k_diff
    // --- micro-cylinder fibre (RTR4 sec. 9.10, brdf/fiber.glsl), texel 12; radians ---
    float fiber_rotation;       // the thread: the tangent turned about n
    float fiber_curvature;      // the thread's largest tilt out of the surface
    float fiber_gamma_v;        // Sadeghi's volume-scattering width
    float fiber_kd;             // Sadeghi's isotropic share of the volume scattering
};

// Row ``id`` of the material table (MATERIAL_TEXELS RGBA32F texels per material, then
// SURFACE_TEXELS more for constant surfaces; see app/common/models.py pack_model_params):
//   texel 0 (f90, 1/p), texel 1 (eta, eta_dielectric), texel 2 (k, gtr_gamma),
//   texel 3 (model group, Fresnel code, specular code, diffuse code), the codes below,
//   texel 6 (sheen_color, sheen_roughness) (RTR4 sec. 9.10, brdf/sheen.glsl).
//   texel 4 (clear coat colour, strength), texel 5 (coat roughness, coat eta, 0, 0),
//   texels 9-11 (k_rim, a_rim, k_inner, a_inner), (c_scatter, w), (k_sheen c_sheen, k_diff)
//   (empirical cloth, RTR4 sec. 9.10, brdf/cloth.glsl),
//   texel 12 (rotation, curvature, gamma_v, k_d) (fibre, RTR4 sec. 9.10, brdf/fiber.glsl).
ModelParams fetch_model_params(sampler2D table, int id) {
    vec4 t0 = texelFetch(table, ivec2(0, id), 0);
    vec4 t1 = texelFetch(table, ivec2(1, id), 0);
    vec4 t2 = texelFetch(table, ivec2(2, id), 0);
    vec4 t4 = texelFetch(table, ivec2(4, id), 0);  // clear coat (RTR4 sec. 9.12)
    vec4 t5 = texelFetch(table, ivec2(5, id), 0);  // clear coat (RTR4 sec. 9.12)
    vec4 t6 = texelFetch(table, ivec2(6, id), 0);  // sheen (RTR4 sec. 9.10)
    vec4 t7 = texelFetch(table, ivec2(7, id), 0);  // thin film (RTR4 sec. 9.11)
    vec4 t8 = texelFetch(table, ivec2(8, id), 0);  // diffraction grating (RTR4 sec. 9.11)
    vec4 t9 = texelFetch(table, ivec2(9, id), 0);  // empirical cloth (RTR4 sec. 9.10)
    vec4 t10 = texelFetch(table, ivec2(10, id), 0);
    vec4 t11 = texelFetch(table, ivec2(11, id), 0);
    vec4 t12 = texelFetch(table, ivec2(12, id), 0);  // micro-cylinder fibre (RTR4 sec. 9.10)
    return ModelParams(t0.rgb, t0.a, t1.rgb, t1.a, t2.rgb, t2.a,
                       t7.r, t7.g, t7.b,            // thin film
                       t6.rgb, t6.a,                // sheen
                       t4.rgb, t4.a, t5.r, t5.g,    // clear coat
                       t8.r, t8.g,                  // diffraction grating
                       t9, t10.rgb, t10.a, t11.rgb, t11.a,  // empirical cloth
                       t12.r, t12.g, t12.b, t12.a);         // micro-cylinder fibre
}

// The model group of material ``id``: which lighting permutation shades its pixels.
int fetch_model_group(sampler2D table, int id) {
    return int(texelFetch(table, ivec2(3, id), 0).r);
}

#if UBER_MODELS
// Sets the run-time model codes from texel 3 of material ``id`` (exact small integers in
// float32; written by app/common/models.py model_codes):
//   .g Fresnel:  fresnel | internal << 2
//   .b specular: ndf | lambda_form << 2 | g2 << 3 | correlation << 6 | anisotropic << 7
//                | multiscatter << 8 | sheen << 9 | clearcoat << 11 | thin_film << 13
//                | diffraction << 14 | fiber << 16
//   .a diffuse:  diffuse
void fetch_model_codes(sampler2D table, int id) {
    ivec4 c = ivec4(texelFetch(table, ivec2(3, id), 0));
    uber_fresnel_model = c.g & 3;
    uber_fresnel_internal = (c.g >> 2) & 1;
    uber_ndf_model = c.b & 3;
    uber_lambda_form = (c.b >> 2) & 1;
    uber_g2_model = (c.b >> 3) & 7;
    uber_correlation = (c.b >> 6) & 1;
    uber_anisotropic = (c.b >> 7) & 1;
    uber_multiscatter = (c.b >> 8) & 1;
    uber_thin_film = (c.b >> 13) & 1;  // thin film (RTR4 sec. 9.11)
    uber_sheen_model = (c.b >> 9) & 3;  // sheen (RTR4 sec. 9.10)
    uber_clearcoat_model = (c.b >> 11) & 3;  // clear coat (RTR4 sec. 9.12)
    uber_diffraction_model = (c.b >> 14) & 3;  // diffraction grating (RTR4 sec. 9.11)
    uber_fiber_model = (c.b >> 16) & 3;  // micro-cylinder fibres (RTR4 sec. 9.10)
    uber_diffuse_model = c.a;
}
#endif

#endif
