// Which model each BRDF term uses (compile-time), and the per-material numbers those
// models need (run-time, from the material table). Twin: app/reference/model.py.
// A pass is compiled once per distinct model: every #if below is resolved by the
// preprocessor, so a scene pays only for the terms its materials select.
#ifndef PBS_MODEL_GLSL
#define PBS_MODEL_GLSL

#define FRESNEL_SCHLICK 0
#define FRESNEL_SCHLICK_GENERALIZED 1
#define FRESNEL_DIELECTRIC 2
#define FRESNEL_CONDUCTOR 3

#define NDF_GGX 0
#define NDF_BECKMANN 1
#define NDF_BLINN_PHONG 2
#define NDF_GTR 3

#define LAMBDA_EXACT 0
#define LAMBDA_RATIONAL 1

#define G2_SEPARABLE 0
#define G2_HEIGHT_CORRELATED 1
#define G2_DIRECTION_CORRELATED 2
#define G2_HEIGHT_DIRECTION_CORRELATED 3
#define G2_HAMMON 4

#define CORRELATION_EXP 0
#define CORRELATION_RATIONAL 1

#define DIFFUSE_LAMBERT 0
#define DIFFUSE_SHIRLEY 1
#define DIFFUSE_ASHIKHMIN_SHIRLEY 2
#define DIFFUSE_BURLEY 3
#define DIFFUSE_OREN_NAYAR 4
#define DIFFUSE_HAMMON 5
#define DIFFUSE_NONE 6
#define DIFFUSE_BURLEY_RENORMALIZED 7

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

// 0 where the specular term has a fused visibility form V = G2/(4 n.l n.v) (the standard
// height-correlated GGX, or Hammon's approximation of it); 1 where it goes through the
// Smith Lambdas and the selected G2. GLSL compiles every function it sees, so the general
// path's functions exist only when this is 1.
#if G2_MODEL == G2_HAMMON || (G2_MODEL == G2_HEIGHT_CORRELATED && NDF_MODEL == NDF_GGX && !ANISOTROPIC)
#define SPECULAR_LAMBDA_G2 0
#else
#define SPECULAR_LAMBDA_G2 1
#endif

// Per-material numbers of the optional models; indices are relative to the medium
// the light arrives from.
struct ModelParams {
    vec3 f90;               // generalised Schlick: F at grazing
    float fresnel_exponent; // generalised Schlick: 1/p
    vec3 eta;               // conductor: n / n1 per channel
    float eta_dielectric;   // dielectric: n2 / n1
    vec3 k;                 // conductor: k / n1 per channel
    float gtr_gamma;        // GTR tail exponent
};

// Row ``id`` of the material table (4 RGBA32F texels per material; see
// app/reference/model.py pack_model_params).
ModelParams fetch_model_params(sampler2D table, int id) {
    vec4 t0 = texelFetch(table, ivec2(0, id), 0);
    vec4 t1 = texelFetch(table, ivec2(1, id), 0);
    vec4 t2 = texelFetch(table, ivec2(2, id), 0);
    return ModelParams(t0.rgb, t0.a, t1.rgb, t1.a, t2.rgb, t2.a);
}

// The model group of material ``id``: which lighting permutation shades its pixels.
int fetch_model_group(sampler2D table, int id) {
    return int(texelFetch(table, ivec2(3, id), 0).r);
}

#endif
