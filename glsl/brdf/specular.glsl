// The specular microfacet BRDF. Twin: app/reference/specular.py.
#ifndef PBS_SPECULAR_GLSL
#define PBS_SPECULAR_GLSL

#include "brdf/model.glsl"
#include "brdf/ndf.glsl"
#include "brdf/masking.glsl"

// The dispatch functions below branch with plain `if` on the model constants of
// brdf/model.glsl: folded at compile time in a specialized pass (only the selected
// model's code remains), run-time branches under UBER_MODELS.

// D(h) of the isotropic NDF that NDF_MODEL selects (RTR4 sec. 9.8).
float D_selected(vec3 n, vec3 h, float alpha, float gtr_gamma) {
    if (NDF_MODEL == NDF_BECKMANN) return D_beckmann(n, h, alpha);
    if (NDF_MODEL == NDF_BLINN_PHONG) return D_blinn_phong(n, h, alpha);
    if (NDF_MODEL == NDF_GTR) return D_GTR(n, h, alpha, gtr_gamma);
    return D_GGX(n, h, alpha);
}

// D(h) of the anisotropic NDF (GGX or Beckmann), alpha_x along the tangent t.
float D_selected_aniso(vec3 n, vec3 t, vec3 b, vec3 h, float alpha_x, float alpha_y) {
    if (NDF_MODEL == NDF_BECKMANN) return D_beckmann_aniso(n, t, b, h, alpha_x, alpha_y);
    return D_GGX_aniso(n, t, b, h, alpha_x, alpha_y);
}

// Smith Lambda of the selected NDF for a direction at cosine c whose roughness seen
// along its azimuth is alpha (RTR4 sec. 9.7).
float Lambda_selected(float c, float alpha, float gtr_gamma) {
    if (NDF_MODEL == NDF_BECKMANN && LAMBDA_FORM == LAMBDA_RATIONAL) {
        return Lambda_beckmann_rational(c, alpha);
    }
    if (NDF_MODEL == NDF_BECKMANN) return Lambda_beckmann(c, alpha);
    if (NDF_MODEL == NDF_BLINN_PHONG) return Lambda_blinn_phong(c, alpha);
    if (NDF_MODEL == NDF_GTR) return Lambda_GTR(c, alpha, gtr_gamma);
    return Lambda_GGX(c, alpha);
}

// The joint masking-shadowing G2 that G2_MODEL selects, from the two Lambdas (the
// chi+(h.l) chi+(h.v) factors are 1 for the half vector). RTR4 sec. 9.7.
float G2_selected(float Lambda_v, float Lambda_l, vec3 n, vec3 l, vec3 v) {
    if (G2_MODEL == G2_SEPARABLE) return G2_separable(Lambda_v, Lambda_l);
    if (G2_MODEL == G2_DIRECTION_CORRELATED || G2_MODEL == G2_HEIGHT_DIRECTION_CORRELATED) {
        float phi = azimuth_difference(n, l, v);
        float lambda_phi;
        if (CORRELATION == CORRELATION_RATIONAL) lambda_phi = lambda_phi_rational(phi);
        else lambda_phi = lambda_phi_exp(phi);
        if (G2_MODEL == G2_DIRECTION_CORRELATED) {
            return G2_direction_correlated(Lambda_v, Lambda_l, lambda_phi);
        }
        return G2_height_direction_correlated(Lambda_v, Lambda_l, lambda_phi);
    }
    return G2_height_correlated(Lambda_v, Lambda_l);
}

#endif
