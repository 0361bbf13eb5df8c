// The BRDF f(l, v) in one include: the model selection (brdf/model.glsl), every term
// (Fresnel, NDF, masking-shadowing, diffuse, multiple scattering, the specular dispatch,
// the cloth sheen layer, the clear coat)
// and the metallic-roughness material with brdf_eval (brdf/material.glsl). What a pass or
// the BRDF probe (app/brdf) includes to shade; a test of one term includes its file alone.
#ifndef PBS_BRDF_GLSL
#define PBS_BRDF_GLSL

#include "common/constants.glsl"
#include "brdf/model.glsl"
#include "brdf/fresnel.glsl"
#include "brdf/thin_film.glsl"
#include "brdf/ndf.glsl"
#include "brdf/masking.glsl"
#include "brdf/diffuse.glsl"
#include "brdf/multiscatter.glsl"
#include "brdf/specular.glsl"
#include "brdf/sheen.glsl"
#include "brdf/clearcoat.glsl"
#include "brdf/material.glsl"

#endif
