// Diffuse (subsurface) terms. Twin: app/reference/diffuse.py.
// Each model returns the BRDF value f_diff (already divided by pi). The caller guarantees
// n.l > 0 and clamps n.v to [MIN_N_DOT_V, 1] (Fd_oren_nayar, which takes vectors, clamps
// them itself).
#ifndef PBS_DIFFUSE_GLSL
#define PBS_DIFFUSE_GLSL

#include "common/constants.glsl"
#include "brdf/fresnel.glsl"

// Lambert 1760; RTR4 sec. 9.3: f = rho_ss / pi, whose directional albedo is rho_ss.
vec3 Fd_lambert(vec3 rho_ss) {
    return rho_ss * INV_PI;
}

// 1 - (1 - x)^5, the Fresnel-complement factor of the smooth-surface diffuse models.
// Precision: with m = 1 - x it equals (1 - m)(1 + m + m^2 + m^3 + m^4) = x (1 + m + ... + m^4),
// a sum of positive terms; the direct 1 - m^5 cancels for small x (x = 1e-4 keeps only
// 3 significant digits in float32, a relative error of 1e-4).
float one_minus_pow5_one_minus(float x) {
    float m = 1.0 - x;
    float m2 = m * m;
    return x * (1.0 + m + m2 + m2 * m + m2 * m2);
}

// Shirley et al. 1997, "A Practitioners' Assessment of Light Reflection Models"; RTR4 eq. 9.63:
//   f = 21/(20 pi) (1 - F0) rho_ss (1 - (1 - n.l)^5)(1 - (1 - n.v)^5),
// smooth-surface diffuse coupled to the specular Fresnel. Directional albedo (F0 = 0):
// (1 - (1 - n.l)^5) rho_ss <= rho_ss, because 2 int_0^1 (1 - (1 - mu)^5) mu dmu = 20/21.
vec3 Fd_shirley(vec3 rho_ss, vec3 F0, float NoL, float NoV) {
    float k = one_minus_pow5_one_minus(NoL) * one_minus_pow5_one_minus(NoV);
    return (21.0 / 20.0 * INV_PI) * k * (1.0 - F0) * rho_ss;
}

// Ashikhmin & Shirley 2000, "An Anisotropic Phong BRDF Model", the diffuse term:
//   f = 28/(23 pi) rho_ss (1 - F0)(1 - (1 - n.l/2)^5)(1 - (1 - n.v/2)^5).
// Directional albedo (F0 = 0): (1 - (1 - n.l/2)^5) rho_ss <= 31/32 rho_ss.
// x/2 is exact in binary floating point, so the same cancellation-free factor serves.
vec3 Fd_ashikhmin_shirley(vec3 rho_ss, vec3 F0, float NoL, float NoV) {
    float k = one_minus_pow5_one_minus(0.5 * NoL) * one_minus_pow5_one_minus(0.5 * NoV);
    return (28.0 / 23.0 * INV_PI) * k * (1.0 - F0) * rho_ss;
}

// The retro-reflective factor shared by both Burley forms:
//   (1 + (F_D90 - 1)(1 - n.l)^5)(1 + (F_D90 - 1)(1 - n.v)^5).
// Precision: each factor is written (1 - p) + F_D90 p with p = (1 - cos)^5 and 1 - p from
// one_minus_pow5_one_minus, a sum of non-negative terms. The direct form cancels when
// F_D90 -> 0 (the renormalised model at r = 0) and cos -> 0.
float burley_retro(float F_D90, float NoL, float NoV) {
    float light = one_minus_pow5_one_minus(NoL) + F_D90 * pow5_one_minus(NoL);
    float view = one_minus_pow5_one_minus(NoV) + F_D90 * pow5_one_minus(NoV);
    return light * view;
}

// Burley 2012, "Physically-Based Shading at Disney", the diffuse model:
//   f = rho_ss/pi (1 + (F_D90 - 1)(1 - n.l)^5)(1 + (F_D90 - 1)(1 - n.v)^5),
//   F_D90 = 0.5 + 2 r (l.h)^2, r = perceptual roughness.
// Not energy conserving: with rho_ss = 1 its directional albedo reaches 1.55 at r = 1 near
// grazing (docs/diffuse-and-multiscatter.md); see Fd_burley_renormalized.
vec3 Fd_burley(vec3 rho_ss, float perceptual_roughness, float NoL, float NoV, float LoH) {
    float F_D90 = 0.5 + 2.0 * perceptual_roughness * LoH * LoH;
    return rho_ss * (INV_PI * burley_retro(F_D90, NoL, NoV));
}

// Lagarde & de Rousiers 2014, "Moving Frostbite to Physically Based Rendering 3.0",
// Listing 1: Burley's model renormalised,
//   energyBias = mix(0, 0.5, r), energyFactor = mix(1, 1/1.51, r),
//   F_D90 = energyBias + 2 r (l.h)^2, f = energyFactor * Burley's product * rho_ss/pi.
vec3 Fd_burley_renormalized(vec3 rho_ss, float perceptual_roughness, float NoL, float NoV,
                            float LoH) {
    float r = perceptual_roughness;
    float energy_bias = 0.5 * r;
    float energy_factor = mix(1.0, 1.0 / 1.51, r);
    float F_D90 = energy_bias + 2.0 * r * LoH * LoH;
    return rho_ss * (INV_PI * energy_factor * burley_retro(F_D90, NoL, NoV));
}

// Oren & Nayar 1994, "Generalization of Lambert's Reflectance Model", the qualitative model:
//   f = rho_ss/pi (A + B max(0, cos(phi_l - phi_v)) sin(a) tan(b)),
//   a = max(theta_l, theta_v), b = min(theta_l, theta_v),
//   A = 1 - 0.5 s2/(s2 + 0.33), B = 0.45 s2/(s2 + 0.09), s2 = sigma^2.
// Vector form, no trigonometry: with l = sin(theta_l) t_l + (n.l) n (t_l the unit tangent at
// azimuth phi_l) and likewise v, l.v - (n.l)(n.v) = sin(theta_l) sin(theta_v) cos(phi_l - phi_v);
// and sin(a) tan(b) = sin(theta_l) sin(theta_v) / cos(b) with cos(b) = max(n.l, n.v), cos
// falling on [0, pi/2]. As sines are >= 0,
//   max(0, cos(phi_l - phi_v)) sin(a) tan(b) = max(0, l.v - n.l n.v) / max(n.l, n.v).
// sigma from alpha: sigma = alpha / sqrt(2), the per-axis rms slope of a Beckmann surface of
// roughness alpha, taken as the matching GGX alpha (docs/diffuse-and-multiscatter.md).
// Precision: near grazing, with l and v at right angles in azimuth, l.v - n.l n.v is a
// small difference divided by a small max(n.l, n.v): ill-conditioned (a rounding of l.v
// of 1e-7 moves the B term by 1e-7 / max(n.l, n.v)); nothing in the form can avoid it.
vec3 Fd_oren_nayar(vec3 rho_ss, float alpha, vec3 n, vec3 l, vec3 v) {
    float NoL = clamp(dot(n, l), 0.0, 1.0);
    float NoV = clamp(dot(n, v), MIN_N_DOT_V, 1.0);
    float s2 = 0.5 * alpha * alpha;
    float A = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float B = 0.45 * s2 / (s2 + 0.09);
    float t = max(dot(l, v) - NoL * NoV, 0.0) / max(NoL, NoV);
    return rho_ss * (INV_PI * (A + B * t));
}

// Hammon 2017, "PBR Diffuse Lighting for GGX+Smith Microsurfaces" (GDC); RTR4 eqs. 9.64-9.66:
//   f = chi+(n.h) rho_ss/pi ((1 - alpha) f_smooth + alpha f_rough + rho_ss f_multi),
//   f_smooth = 21/20 (1 - F0)(1 - (1 - n.l)^5)(1 - (1 - n.v)^5),
//   f_rough  = k_facing (0.9 - 0.4 k_facing)((0.5 + n.h)/(n.h)), k_facing = 0.5 + 0.5 l.v,
//   f_multi  = 0.3641 alpha            (Hammon's 0.1159 alpha outside the 1/pi; 0.1159 pi).
// n.h > 0 whenever n.l > 0 and n.v > 0 (n.h = (n.l + n.v)/|l + v|), so chi+ is 1 here.
// Not energy conserving for rho_ss near 1: with rho_ss = 1 the directional albedo reaches
// 1.18 at alpha = 1 near grazing (docs/diffuse-and-multiscatter.md).
// Guard: n.h is floored at MIN_N_DOT_V/2. While v is truly above the horizon,
// n.h >= (n.l + n.v)/2 >= MIN_N_DOT_V/2 already, so nothing changes there; but the caller's h
// comes from the unclamped v, and a normal-mapped v below the horizon (n.v < -n.l, e.g.
// n.l = 0.01, n.v = -0.3) gave n.h = 0 and f_rough = 0.5/0 = Inf (tests/test_stability_brdf.py).
vec3 Fd_hammon(vec3 rho_ss, vec3 F0, float alpha, float NoL, float NoV, float NoH, float LoV) {
    vec3 f_smooth = (21.0 / 20.0) * (1.0 - F0) *
                    (one_minus_pow5_one_minus(NoL) * one_minus_pow5_one_minus(NoV));
    float k_facing = 0.5 + 0.5 * LoV;
    float NoH_safe = max(NoH, 0.5 * MIN_N_DOT_V);
    float f_rough = k_facing * (0.9 - 0.4 * k_facing) * ((0.5 + NoH_safe) / NoH_safe);
    float f_multi = 0.3641 * alpha;
    return rho_ss * INV_PI * ((1.0 - alpha) * f_smooth + alpha * f_rough + rho_ss * f_multi);
}

#endif
