// Which model each BRDF term uses, and the per-material numbers those models need
// (run-time, from the material table). The model names and their codes are defined once in
// app/common/models.py, the material row's fields in app/common/material_fields.py; the
// assembler (app/gl/shaders.py) generates their constants (FRESNEL_SCHLICK 0, NDF_GGX 0,
// ..., DIFFUSE_BURLEY_RENORMALIZED 7), the struct ModelParams and its fetch functions at
// the top of every program.
// A pass is compiled once per distinct model: FRESNEL_MODEL, NDF_MODEL, ... are #define'd
// integer constants, so the plain `if (NDF_MODEL == NDF_BECKMANN)` of each dispatch
// function (material.glsl, specular.glsl) is folded by the compiler and a scene pays only
// for the terms its materials select.
//
// UBER_MODELS 1 (the bench's `uber` variant, docs/performance.md "Specialization"): one
// program for every material. The same names then expand to globals that
// fetch_model_codes() sets per pixel from the material table (both generated into the
// header), and the SAME dispatch code becomes run-time branches; every model function, the
// multiple-scattering table and the anisotropic tangent frame are compiled in.
#ifndef PBS_MODEL_GLSL
#define PBS_MODEL_GLSL

#ifndef UBER_MODELS
#define UBER_MODELS 0
#endif

// Under UBER_MODELS the header already holds the run-time globals, the defines that name
// them and fetch_model_codes(), generated (app/gl/shaders.py).
#if !UBER_MODELS
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
// A coloured dielectric F0 (glTF KHR_materials_specular): F0 times the row's specular_color.
#ifndef SPECULAR_COLOR
#define SPECULAR_COLOR 0
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
// The empirical cloth's wrapped cosine (RTR4 sec. 9.10): Filament's unless a pass says otherwise.
#ifndef CLOTH_WRAP_FORM
#define CLOTH_WRAP_FORM CLOTH_WRAP_FILAMENT
#endif
#endif  // !UBER_MODELS

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
// in a specialized pass, a per-pixel one under UBER_MODELS. Each macro is one line: GLSL
// before 4.20 has no backslash line continuation (docs/architecture.md, "Portable GLSL").
#define SPECULAR_GGX_ISOTROPIC (NDF_MODEL == NDF_GGX && ANISOTROPIC == 0)
#define SPECULAR_FUSED_V (G2_MODEL == G2_HAMMON || (G2_MODEL == G2_HEIGHT_CORRELATED && SPECULAR_GGX_ISOTROPIC))
#define SPECULAR_LAMBDA_G2 (!SPECULAR_FUSED_V)

// The per-material numbers (struct ModelParams), fetch_model_params(), fetch_model_group()
// and, under UBER_MODELS, fetch_model_codes() are generated from the one declaration of
// the material row (app/common/material_fields.py, app/common/models.py material_glsl)
// into every program's header (app/gl/shaders.py): a field is added there, not here.

#endif
