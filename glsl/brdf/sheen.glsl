// A cloth sheen layer over any base BRDF (RTR4 sec. 9.10). Twin: app/reference/sheen.py.
// Microfacet sheen: an NDF whose microfacets lie near the horizon (fibres standing up from
// the cloth), a soft visibility term instead of Smith's (or, SHEEN_CHARLIE_SMITH, Charlie's
// own fitted Smith Lambda), no Fresnel:
//   f_sheen = sheen_color D(h) V(n.l, n.v),
// layered over the base as glTF's KHR_materials_sheen does (its "albedo scaling"):
//   f = f_sheen + f_base (1 - max(sheen_color) max(E(n.l), E(n.v))),
// E(mu) the sheen lobe's directional albedo with sheen_color = 1, read from a table the
// float64 twin computes by quadrature (u_sheen_table, app/common/data/sheen_table_64.npy).
// Everything is inside #if UBER_MODELS || SHEEN_MODEL != SHEEN_NONE: a material without
// sheen compiles exactly as before.
#ifndef PBS_SHEEN_GLSL
#define PBS_SHEEN_GLSL

#include "common/constants.glsl"
#include "brdf/model.glsl"
#include "brdf/ndf.glsl"

#if UBER_MODELS || SHEEN_MODEL != SHEEN_NONE

// Ashikhmin & Premoze 2007's amplitude of the inverted Gaussian (their velvet's A = 4).
const float ASHIKHMIN_AMPLITUDE = 4.0;
// The inverted Gaussian is dropped where its exponent exceeds float32's normal range.
const float ASHIKHMIN_EXPONENT_CUTOFF = 87.0;

// alpha = r^2 with r floored at MIN_PERCEPTUAL_ROUGHNESS, as the base's alpha.
float sheen_alpha(float sheen_roughness) {
    float r = max(sheen_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    return r * r;
}

// Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF" ("Charlie"):
//   D(m) = chi+(n.m) (2 + 1/alpha) sin(theta_m)^(1/alpha) / (2 pi).
// Precision: sin^(1/alpha) = exp(ln(sin^2)/(2 alpha)), 1/alpha up to 494; at the peak near
// the horizon ln(sin^2) = ln(1 - (n.m)^2) by log_one_minus, elsewhere ln(|n x m|^2) with
// |n x m|^2 floored at 1e-30 only to keep ln(0) out (D < 1e-14 there).
float D_charlie(vec3 n, vec3 m, float alpha) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    vec3 nxm = cross(n, m);
    float s2 = max(dot(nxm, nxm), 1e-30);
    float c2 = NoM * NoM;
    float inv_a = 1.0 / alpha;
    float ln_s2 = c2 < 0.25 ? log_one_minus(c2) : log(s2);
    return (2.0 + inv_a) * (0.5 * INV_PI) * exp(0.5 * inv_a * ln_s2);
}

// Ashikhmin, Premoze & Shirley 2000; Ashikhmin & Premoze 2007, "Distribution-based BRDFs"
// (inverted Gaussian velvet, amplitude k_amp = 4; RTR4 sec. 9.10):
//   D(m) = chi+(n.m) (1 + k_amp exp(-cot^2(theta_m)/alpha^2) / sin^4(theta_m)) / (pi (1 + k_amp alpha^2)).
// Precision: cot^2/alpha^2 = (n.m)^2 / (alpha^2 |n x m|^2); the exponent test is written as
// a product, so sin = 0 needs no division, and where it passes sin^2 >= 1/88 (no overflow).
float D_ashikhmin(vec3 n, vec3 m, float alpha) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    vec3 nxm = cross(n, m);
    float s2 = dot(nxm, nxm);
    float a2 = alpha * alpha;
    float c2 = NoM * NoM;
    float bump = 0.0;
    if (c2 <= ASHIKHMIN_EXPONENT_CUTOFF * a2 * s2) {
        bump = ASHIKHMIN_AMPLITUDE * exp(-c2 / (a2 * s2)) / (s2 * s2);
    }
    return (1.0 + bump) / (PI * (1.0 + ASHIKHMIN_AMPLITUDE * a2));
}

// Ashikhmin & Premoze 2007; Neubelt & Pettineo 2013, "Crafting a Next-Gen Material Pipeline
// for The Order: 1886": V = 1/(4 (n.l + n.v - n.l n.v)). The sum is taken as
// n.l + n.v (1 - n.l), all terms >= 0: no cancellation; >= MIN_N_DOT_V, so V <= 2500.
float V_neubelt(float NoL, float NoV) {
    return 1.0 / (4.0 * (NoL + NoV * (1.0 - NoL)));
}

#if UBER_MODELS || SHEEN_MODEL == SHEEN_CHARLIE_SMITH
// Estevez & Kulla 2017's fit to ln Lambda of the Charlie NDF (RTR4 sec. 9.7, 9.10),
//   L(x) = a/(1 + b x^c) + d x + e,
// each coefficient p1 + t (p0 - p1), t = (1 - alpha)^2, between their fits at r = 0 (p0) and
// r = 1 (p1); their r is D's exponent parameter, this project's alpha (docs/cloth.md).
// x^c is written 0 at x = 0 (n.v = 1 reaches L(1 - 1)) rather than trusting pow(0, c).
float charlie_L(float x, float alpha) {
    float t = (1.0 - alpha) * (1.0 - alpha);
    float a = 21.5473 + t * (25.3245 - 21.5473);
    float b = 3.82987 + t * (3.32435 - 3.82987);
    float c = 0.19823 + t * (0.16801 - 0.19823);
    float d = -1.97760 + t * (-1.27393 - -1.97760);
    float e = -4.32054 + t * (-4.85967 - -4.32054);
    float xc = x > 0.0 ? pow(x, c) : 0.0;
    return a / (1.0 + b * xc) + d * x + e;
}

// Lambda(mu) = exp(L(mu)) for mu < 0.5, exp(2 L(0.5) - L(1 - mu)) otherwise. Precision:
// L <= a + e = 20.47, so Lambda <= 7.7e8 (float32 holds it); at mu = 1 Lambda ~ 1e-8.
float Lambda_charlie(float mu, float alpha) {
    if (mu < 0.5) return exp(charlie_L(mu, alpha));
    return exp(2.0 * charlie_L(0.5, alpha) - charlie_L(1.0 - mu, alpha));
}

// Height-correlated Smith visibility with Charlie's Lambda (RTR4 sec. 9.7):
//   V = G2 / (4 n.l n.v) = 1 / (4 n.l n.v (1 + Lambda(n.l) + Lambda(n.v))).
// n.l enters at n.v's floor MIN_N_DOT_V: below it the fit's Lambda flattens out (7.6e8
// where the true one grows as 1/mu) and f would grow as 1/n.l; so f stays bounded and
// reciprocal at the clamps too. Precision: one reciprocal of a product of positive
// factors in [4e-8, 7e9]: no Inf or NaN. Estevez & Kulla's terminator softening
// (Lambda(n.l)^(1 + 2 (1 - n.l)^8), light only) is left out: it breaks f(l, v) = f(v, l).
float V_charlie_smith(float NoL, float NoV, float alpha) {
    float mu_l = max(NoL, MIN_N_DOT_V);
    float lam = 1.0 + Lambda_charlie(mu_l, alpha) + Lambda_charlie(NoV, alpha);
    return 1.0 / (4.0 * (mu_l * NoV) * lam);
}
#endif

// The sheen NDF of the selected model (SHEEN_CHARLIE_SMITH shares Charlie's).
float D_sheen_selected(vec3 n, vec3 h, float alpha) {
    if (SHEEN_MODEL == SHEEN_ASHIKHMIN) return D_ashikhmin(n, h, alpha);
    return D_charlie(n, h, alpha);
}

// The sheen visibility of the selected model: Neubelt's, or Charlie's Smith G2.
float V_sheen_selected(float NoL, float NoV, float alpha) {
#if UBER_MODELS || SHEEN_MODEL == SHEEN_CHARLIE_SMITH
    if (SHEEN_MODEL == SHEEN_CHARLIE_SMITH) return V_charlie_smith(NoL, NoV, alpha);
#endif
    return V_neubelt(NoL, NoV);
}

// f_sheen = sheen_color D(h) V(n.l, n.v).
vec3 f_sheen_selected(vec3 sheen_color, float sheen_roughness, vec3 n, vec3 h,
                      float NoL, float NoV) {
    float alpha = sheen_alpha(sheen_roughness);
    return sheen_color * (D_sheen_selected(n, h, alpha) * V_sheen_selected(NoL, NoV, alpha));
}

// --- the albedo table ---
// u_sheen_table (app/render/tables.py sheen_texture): RGB32F, NEAREST, 64 x 64; texel (j, i)
// = (E_charlie, E_ashikhmin, E_charlie_smith) at mu_j = (j/63)^4 and
// r_i = 0.045 + 0.955 (i/63)^2, the grids
// of the multiple-scattering table. Bilinear by hand in (sqrt(sqrt(mu)), sqrt((r - 0.045)
// / 0.955)) with texelFetch, the twin's sums (GPU filtering uses fixed-point weights).
uniform sampler2D u_sheen_table;

int sheen_cell(float s, int n, out float t) {
    int i = min(int(s), n - 2);
    t = s - float(i);
    return i;
}

// E(mu, r) of the selected model's lobe (sheen_color = 1).
float sheen_E(float mu, float sheen_roughness) {
    ivec2 size = textureSize(u_sheen_table, 0);
    float r = clamp(sheen_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    float u = (r - MIN_PERCEPTUAL_ROUGHNESS) / (1.0 - MIN_PERCEPTUAL_ROUGHNESS);
    float tx, ty;
    int j = sheen_cell(sqrt(sqrt(clamp(mu, 0.0, 1.0))) * float(size.x - 1), size.x, tx);
    int i = sheen_cell(sqrt(u) * float(size.y - 1), size.y, ty);
    vec3 a = texelFetch(u_sheen_table, ivec2(j, i), 0).rgb;
    vec3 b = texelFetch(u_sheen_table, ivec2(j + 1, i), 0).rgb;
    vec3 c = texelFetch(u_sheen_table, ivec2(j, i + 1), 0).rgb;
    vec3 d = texelFetch(u_sheen_table, ivec2(j + 1, i + 1), 0).rgb;
    vec3 e = (1.0 - ty) * ((1.0 - tx) * a + tx * b) + ty * ((1.0 - tx) * c + tx * d);
    if (SHEEN_MODEL == SHEEN_CHARLIE_SMITH) return e.b;
    return SHEEN_MODEL == SHEEN_ASHIKHMIN ? e.g : e.r;
}

// glTF KHR_materials_sheen's albedo scaling, 1 - max(sheen_color) max(E(n.l), E(n.v)):
// the light the sheen leaves to the base. The max over both directions (glTF's min of the
// two scalings) keeps f reciprocal. Clamped at 0: Charlie's E with Neubelt's V (and, less,
// with the fitted Smith Lambda) exceeds 1 toward grazing at low sheen roughness
// (docs/cloth.md), where the base would turn negative.
float sheen_scaling(vec3 sheen_color, float sheen_roughness, float NoL, float NoV) {
    float c = max(sheen_color.r, max(sheen_color.g, sheen_color.b));
    float E = max(sheen_E(NoL, sheen_roughness), sheen_E(NoV, sheen_roughness));
    return clamp(1.0 - c * E, 0.0, 1.0);
}

// --- the sheen under image-based light (twin: sheen_environment) ---
// L = sheen_color E(n.v) L_charlie(n, r) + L_base (1 - max(sheen_color) E(n.v)): the glTF
// Sample Viewer's split sum for the sheen, with L_charlie the environment prefiltered by the
// Charlie lobe (weight D_charlie(h) (R.l)+ about the read direction, n = v = R), a zonal
// kernel, so it is the environment's SH9 with band l scaled by k_l (Funk-Hecke). With
// p = 1/(2 alpha) the kernel is mu (1 - mu)^p in mu = R.l (Beta-function moments):
// k0 = 1, k1 = 2/(p + 3), k2 = 9/((p + 3)(p + 4)) - 1/2 (docs/cloth.md, "Under an
// environment"). Read along n, not R: measured closer to the lobe's integral (docs/cloth.md).
vec2 charlie_sh_bands(float sheen_roughness) {
    float p = 0.5 / sheen_alpha(sheen_roughness);
    return vec2(2.0 / (p + 3.0), 9.0 / ((p + 3.0) * (p + 4.0)) - 0.5);
}

// L_charlie(d, r) from the SH9 coefficients L (order of app/reference/ibl.py sh9_basis):
// Ramamoorthi & Hanrahan's irradiance sums per band (which carry A_0 = pi, A_1 = 2 pi/3,
// A_2 = pi/4), reweighted by k_l / A_l; clamped at 0 (SH ringing).
vec3 charlie_prefiltered_sh(vec3 L[9], vec3 d, float sheen_roughness) {
    const float c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708;
    vec2 k = charlie_sh_bands(sheen_roughness);
    vec3 band0 = c4 * L[0];
    vec3 band1 = 2.0 * c2 * (L[3] * d.x + L[1] * d.y + L[2] * d.z);
    vec3 band2 = c1 * L[8] * (d.x * d.x - d.y * d.y) + c3 * L[6] * d.z * d.z - c5 * L[6]
               + 2.0 * c1 * (L[4] * d.x * d.y + L[7] * d.x * d.z + L[5] * d.y * d.z);
    return max((band0 + 1.5 * k.x * band1 + 4.0 * k.y * band2) * INV_PI, vec3(0.0));
}

// The environment's sheen over the base's environment light (diffuse, surface: its split
// sum's two parts, which render.terms selects): the base scaled by 1 - max(c) E(n.v) (E at
// n.v alone: a whole environment has no single n.l), the sheen added as surface reflection.
void sheen_environment(vec3 sheen_color, float sheen_roughness, float NoV, vec3 n, vec3 L[9],
                       inout vec3 diffuse, inout vec3 surface) {
    float E = sheen_E(NoV, sheen_roughness);
    float c = max(sheen_color.r, max(sheen_color.g, sheen_color.b));
    float scale = clamp(1.0 - c * E, 0.0, 1.0);
    diffuse *= scale;
    surface = surface * scale + sheen_color * (E * charlie_prefiltered_sh(L, n, sheen_roughness));
}

#endif  // UBER_MODELS || SHEEN_MODEL != SHEEN_NONE

#endif
