// The terms of a clear coat: a transparent, absorbing layer of index eta (relative to the
// medium around the object) over any base BRDF (RTR4 sec. 9.12). Only the terms live here;
// brdf/material.glsl composes them with the base (clearcoat_factors).
// Twin: app/reference/clearcoat.py (same names, same order of operations).
//
// The coat's terms take the coat's own normal, which brdf/material.glsl passes in: the
// base's shading normal, or where they differ (RTR4 sec. 9.12, "layers may have different
// normals") the one in the G-buffer's RT4 (docs/layered.md).
#ifndef PBS_CLEARCOAT_GLSL
#define PBS_CLEARCOAT_GLSL

#include "common/constants.glsl"
#include "brdf/fresnel.glsl"
#include "brdf/ndf.glsl"
#include "brdf/masking.glsl"

// RTR4 eq. 9.17: F0 = ((eta - 1)/(eta + 1))^2 of the coat's outer interface.
float clearcoat_F0(float eta) {
    float r = (eta - 1.0) / (eta + 1.0);
    return r * r;
}

// Schlick 1994 (RTR4 sec. 9.5) with the coat's scalar F0: the coat is a dielectric, the
// same reflectance in every channel.
float F_clearcoat_schlick(float F0c, float cos_theta) {
    return F0c + (1.0 - F0c) * pow5_one_minus(clamp(cos_theta, 0.0, 1.0));
}

// Snell's law, RTR4 eq. 9.31: the cosine inside the coat of a direction whose cosine
// outside is mu, cos_t = sqrt(1 - (1 - mu^2)/eta^2) = sqrt((eta - 1)(eta + 1) + mu^2)/eta.
// Precision: as in F_dielectric, d = (eta - 1)(eta + 1) is exact near eta = 1 where
// eta^2 - 1 would cancel; for eta >= 1 the root's argument is >= mu^2 (no TIR going in).
float clearcoat_cos_refracted(float eta, float mu) {
    float d = (eta - 1.0) * (eta + 1.0);
    return sqrt(max(d + mu * mu, 0.0)) / eta;
}

// The coat's own reflection (Filament; glTF KHR_materials_clearcoat): an isotropic GGX
// lobe of the coat's roughness with the height-correlated Smith visibility and the
// Schlick Fresnel of its index, RTR4 eq. 9.34: F(h, l) D(h) G2 / (4 n.l n.v).
float f_clearcoat_ggx(float alpha_c, float F0c, vec3 n, vec3 h, float NoL, float NoV,
                      float LoH) {
    return F_clearcoat_schlick(F0c, LoH) * (D_GGX(n, h, alpha_c) *
                                            V_height_correlated_GGX(NoL, NoV, alpha_c));
}

// What one crossing of the coat lets through, 1 - c F(mu) with Schlick's F, written as
//   (1 - c) + c (1 - F0) (1 - (1 - mu)^5),  1 - (1 - x)^5 = x (5 - 10x + 10x^2 - 5x^3 + x^4).
// Precision: at grazing mu, F is within ulps of 1 and 1 - F cancels in float32 (at
// mu = 1e-7 the 1 - mu inside Schlick already rounds by 19 %); the polynomial keeps full
// relative precision there. c = 0 gives exactly 1.
float T_clearcoat_schlick(float c, float F0c, float mu) {
    float x = clamp(mu, 0.0, 1.0);
    float q = x * (5.0 + x * (-10.0 + x * (10.0 + x * (-5.0 + x))));
    return (1.0 - c) + c * ((1.0 - F0c) * q);
}

// Filament's attenuation of the base by the coat, here on the way in AND out: the light
// the coat reflects at n.l and at n.v never reaches (leaves) the base. With strength c,
//   T = (1 - c F(n.l)) (1 - c F(n.v)),
// symmetric in l and v, so the composition stays reciprocal (Filament weights by
// 1 - F(v.h) once, which is not).
float T_clearcoat_filament(float c, float F0c, float NoL, float NoV) {
    return T_clearcoat_schlick(c, F0c, NoL) * T_clearcoat_schlick(c, F0c, NoV);
}

// Beer-Lambert absorption (RTR4 sec. 14.1.2) along the refracted path down and up:
// T0 is the coat's transmittance at normal incidence through its thickness once, so a
// path at angle theta_t inside keeps T0^(1/cos theta_t), and the two legs
//   A = T0^(1/cos_t(n.l) + 1/cos_t(n.v)).
// Precision: T0^e as exp2(e log2 T0), written out at T0 = 0 (pow(0, e) is undefined in
// GLSL); T0 = 1 gives exactly 1 for every e (log2(1) = 0), so a clear coat costs no tint.
vec3 A_clearcoat_beer_lambert(vec3 T0, float eta, float NoL, float NoV) {
    float e = 1.0 / clearcoat_cos_refracted(eta, NoL) + 1.0 / clearcoat_cos_refracted(eta, NoV);
    vec3 lg = log2(max(T0, vec3(1e-30)));
    return vec3(T0.r > 0.0 ? exp2(e * lg.r) : 0.0, T0.g > 0.0 ? exp2(e * lg.g) : 0.0,
                T0.b > 0.0 ? exp2(e * lg.b) : 0.0);
}

// The F0 of a dielectric base under the coat: the base's interface is with the coat, not
// with the medium. From its F0 in the medium, s = sqrt(F0), its relative index is
// n = (1 + s)/(1 - s) (RTR4 eq. 9.18), and against the coat n/eta:
//   F0' = ((n - eta)/(n + eta))^2 = (((1 + s) - eta (1 - s)) / ((1 + s) + eta (1 - s)))^2.
// Written without (1 - s) in a denominator, so F0 = 1 (s = 1) gives 1, not 0/0. Filament
// fits the same curve for eta = 1.5 (f0ClearCoatToSurface). A base as dense as the coat
// (n = eta) reflects nothing: RTR4's weak substrate reflection under a coat.
float f0_under_clearcoat(float f0, float eta) {
    float s = sqrt(clamp(f0, 0.0, 1.0));
    float a = 1.0 + s;
    float b = eta * (1.0 - s);
    float r = (a - b) / (a + b);
    return r * r;
}

// Snell's law (RTR4 eq. 9.31) for a unit direction d outside, pointing away from the
// surface: the same direction inside the coat, d_t = (d - (n.d) n)/eta + cos_t n. Unit for
// any n.d (cos_t from (n.d)^2), so a direction slightly below the horizon (interpolated
// normals) lands above it, where the base's clamps take over.
vec3 clearcoat_refract_in(float eta, vec3 n, vec3 d) {
    float mu = dot(n, d);
    float cos_t = clearcoat_cos_refracted(eta, mu);
    return (d - mu * n) / eta + cos_t * n;
}

// What refraction does to radiance, crossing in and back out (the n^2 law of radiance,
// Veach 1997 sec. 5.2): a BRDF evaluated with the refracted directions is worth 1/eta^2
// of itself outside, since cos_t d omega_t = cos d omega / eta^2.
float clearcoat_solid_angle_compression(float eta) {
    return 1.0 / (eta * eta);
}

// --- the coat-base inter-reflection series (CLEARCOAT_WEIDLICH_WILKIE_SERIES) ---
// Least-squares fit of the GGX single-scattering average albedo's loss 1 - E_avg(r)
// (Kulla & Conty 2017; the height-correlated table of app/reference/multiscatter.py) on r
// in [0, 1]: r^2 (a + b r + c r^2), within 2.2e-3 of the table, so the series needs no table.
float E_avg_ggx_fit(float perceptual_roughness) {
    float r = clamp(perceptual_roughness, 0.0, 1.0);
    return 1.0 - max(r * r * (-0.258 + r * (2.087 + r * -1.240)), 0.0);
}

// r_i: the fraction of diffuse light inside the coat that its top reflects back down,
// 1 - (1 - c F_avg)/eta_c^2, F_avg = F0 + (1 - F0)/21 (Schlick's hemispherical average, the
// crossings' own F). What escapes, (1 - c F_avg)/eta_c^2, is what a Lambertian base seen
// through the coat, f_base(l_t, v_t)/eta_c^2 times 1 - c F(n.v), integrates to.
float clearcoat_internal_reflectance(float c, float F0c, float eta_c) {
    float F_avg = F0c + (1.0 - F0c) / 21.0;
    return 1.0 - (1.0 - c * F_avg) / (eta_c * eta_c);
}

// r_s: the share of a GGX base lobe of width alpha that the coat's top reflects back down
// on its first return: c F0 near the mirror direction (a smooth lobe), r_i for the part
// past the critical angle, weighted by GGX's cosine-weighted half-vector CDF at normal
// incidence (Walter et al. 2007), s = alpha^2 / (alpha^2 + tan^2(theta_c/2)).
float clearcoat_lobe_trapping(float c, float F0c, float eta_c, float r_i, float alpha) {
    float cos_c = sqrt(max(1.0 - 1.0 / (eta_c * eta_c), 0.0));
    float tan2 = (1.0 - cos_c) / (1.0 + cos_c);
    float a2 = alpha * alpha;
    float s = a2 / (a2 + tan2);
    return (1.0 - s) * (c * F0c) + s * r_i;
}

#endif
