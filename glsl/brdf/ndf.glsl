// Normal distribution functions D(m). Twin: app/reference/ndf.py.
#ifndef PBS_NDF_GLSL
#define PBS_NDF_GLSL

#include "common/constants.glsl"

// Conventions: n is the normal, m the microfacet normal, t and b the tangent and bitangent
// (n, t, b orthonormal); alpha = perceptual_roughness^2. Every D here carries chi+(n.m) and
// is normalised: integral of D(m)(n.m) dm over the hemisphere = 1 (RTR4 sec. 9.7).
// Precision: wherever a D needs 1 - (n.m)^2 = sin^2(theta_m) it is taken as |n x m|^2
// (Lagrange's identity); the direct form cancels catastrophically near the peak in float32.

// --- numerical helpers (brdf/masking.glsl uses them too) ---

// (e^x - 1)/x, = 1 at x = 0. GLSL has no expm1, and exp(x) - 1 loses -log2|x| bits to
// cancellation for small |x|: |x| < 1 uses the Taylor series through x^9/10! (truncation
// < 2.6e-8 relative), |x| >= 1 the direct form (cancellation costs at most e/(e - 1) = 1.6x).
float expm1_over_x(float x) {
    if (abs(x) < 1.0) {
        return 1.0 + x * (1.0 / 2.0 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0
            + x * (1.0 / 720.0 + x * (1.0 / 5040.0 + x * (1.0 / 40320.0 + x * (1.0 / 362880.0
            + x * (1.0 / 3628800.0)))))))));
    }
    return (exp(x) - 1.0) / x;
}

// ln(1 - x), 0 <= x < 1. GLSL has no log1p: log(1.0 - x) keeps only the bits of x that
// survive 1 - x. For x < 1/4 use ln(1 - x) = -2 atanh(y), y = x/(2 - x) <= 1/7, by its odd
// series through y^9 (truncation < 1e-9 relative). Above, 1 - x loses nothing that x knew
// (it is exact from x = 1/2 up); a caller whose 1 - x is better known than x should use it.
float log_one_minus(float x) {
    if (x < 0.25) {
        float y = x / (2.0 - x);
        float y2 = y * y;
        return -2.0 * y * (1.0 + y2 * (1.0 / 3.0 + y2 * (1.0 / 5.0 + y2 * (1.0 / 7.0
            + y2 * (1.0 / 9.0)))));
    }
    return log(1.0 - x);
}

// --- isotropic NDFs ---

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (GGX);
// Trowbridge & Reitz 1975. RTR4 sec. 9.8:
//   D(m) = chi+(n.m) alpha^2 / (pi (1 + (n.m)^2 (alpha^2 - 1))^2).
// Precision: the denominator is rewritten as (n.m)^2 alpha^2 + (1 - (n.m)^2), with
// 1 - (n.m)^2 = |n x m|^2 by Lagrange's identity; near the peak of a smooth lobe the
// direct form 1 - (n.m)^2 cancels catastrophically in float32.
float D_GGX(vec3 n, vec3 m, float alpha) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    vec3 nxm = cross(n, m);
    float a2 = alpha * alpha;
    float d = NoM * NoM * a2 + dot(nxm, nxm);
    return a2 / (PI * d * d);
}

// Beckmann & Spizzichino 1963; RTR4 eq. 9.35:
//   D(m) = chi+(n.m) / (pi alpha^2 (n.m)^4) exp(((n.m)^2 - 1) / (alpha^2 (n.m)^2)).
// Precision: (n.m)^2 - 1 = -|n x m|^2 (Lagrange). exp(-e) is below float32's normal range
// for e > 87, where D < 5e-34; returning 0 there also keeps 0/0 out when (n.m)^4 underflows
// (n.m < 1e-10).
float D_beckmann(vec3 n, vec3 m, float alpha) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    vec3 nxm = cross(n, m);
    float a2 = alpha * alpha;
    float c2 = NoM * NoM;
    float e = dot(nxm, nxm) / (a2 * c2);  // tan^2(theta_m) / alpha^2
    if (e > 87.0) return 0.0;
    return exp(-e) / (PI * a2 * c2 * c2);
}

// Walter et al. 2007's mapping between Blinn-Phong's exponent and Beckmann's alpha,
// alpha_p = 2/alpha^2 - 2: the material keeps alpha = r^2, so every NDF is compared at
// matched roughness (alpha = 1 gives alpha_p = 0, the uniform distribution 1/pi).
float blinn_phong_exponent(float alpha) {
    return 2.0 / (alpha * alpha) - 2.0;
}

// Blinn 1977, normalised (RTR4 sec. 9.8.1): D(m) = chi+(n.m) (alpha_p + 2)/(2 pi) (n.m)^alpha_p.
// Precision: alpha_p reaches 5e5 at the roughness floor, so pow(n.m, alpha_p) would multiply
// n.m's rounding by 5e5. Instead (n.m)^alpha_p = exp(alpha_p/2 ln(1 - |n x m|^2)) with an
// accurate ln(1 - x) for small x; away from the peak (|n x m|^2 >= 1/4) ln((n.m)^2) is exact
// enough directly (n.m is floored at 1e-30 only so that alpha_p = 0 never meets ln(0)).
float D_blinn_phong(vec3 n, vec3 m, float alpha) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    float p = blinn_phong_exponent(alpha);
    vec3 nxm = cross(n, m);
    float s2 = dot(nxm, nxm);
    float ln_c2 = s2 < 0.25 ? log_one_minus(s2) : 2.0 * log(max(NoM, 1e-30));
    return (p + 2.0) * (0.5 * INV_PI) * exp(0.5 * p * ln_c2);
}

// Burley 2012, "Physically-Based Shading at Disney", appendix B (generalised Trowbridge-Reitz):
//   D(m) = c / (alpha^2 (n.m)^2 + 1 - (n.m)^2)^gamma,
//   c = (gamma - 1)(alpha^2 - 1) / (pi (1 - (alpha^2)^(1 - gamma))),  c = (alpha^2 - 1)/(pi ln alpha^2)
// at gamma = 1; gamma = 2 is GGX. Precision: with L = ln(alpha^2) and E(x) = (e^x - 1)/x the
// peak value is D(n) = c alpha^(-2 gamma) = E(L) / (pi alpha^2 E((gamma - 1) L)), one form
// for every gamma > 0 and alpha in (0, 1] with no 0/0 at gamma = 1 or alpha = 1 (where E = 1).
// Dividing the base by alpha^2 too, d = (n.m)^2 + |n x m|^2/alpha^2 lies in [1, 1/alpha^2], so
// pow(d, gamma) never underflows and overflows (d^gamma > 3.4e38, only for gamma > 7) only
// where D < 1e-32, which then returns 0.
float gtr_peak(float alpha, float gamma) {
    float a2 = alpha * alpha;
    float L = log(a2);
    return expm1_over_x(L) / (PI * a2 * expm1_over_x((gamma - 1.0) * L));
}

float D_GTR(vec3 n, vec3 m, float alpha, float gamma) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    vec3 nxm = cross(n, m);
    float d = NoM * NoM + dot(nxm, nxm) / (alpha * alpha);
    return gtr_peak(alpha, gamma) / pow(d, gamma);
}

// --- anisotropic NDFs (alpha_x along t, alpha_y along b) ---

// Anisotropic GGX; Burley 2012; Heitz 2014; RTR4 sec. 9.8.1 (eqs. 9.37-9.38):
//   D(m) = chi+(n.m) / (pi ax ay ((t.m)^2/ax^2 + (b.m)^2/ay^2 + (n.m)^2)^2).
// The three squares are added, never subtracted: no cancellation anywhere.
float D_GGX_aniso(vec3 n, vec3 t, vec3 b, vec3 m, float alpha_x, float alpha_y) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    float x = dot(t, m) / alpha_x;
    float y = dot(b, m) / alpha_y;
    float d = x * x + y * y + NoM * NoM;
    return 1.0 / (PI * alpha_x * alpha_y * d * d);
}

// Anisotropic Beckmann; Ward 1992; RTR4 sec. 9.8.1 (eqs. 9.37-9.38):
//   D(m) = chi+(n.m) / (pi ax ay (n.m)^4) exp(-((t.m)^2/ax^2 + (b.m)^2/ay^2) / (n.m)^2).
// Same exponent cut-off as D_beckmann.
float D_beckmann_aniso(vec3 n, vec3 t, vec3 b, vec3 m, float alpha_x, float alpha_y) {
    float NoM = dot(n, m);
    if (NoM <= 0.0) return 0.0;
    float x = dot(t, m) / alpha_x;
    float y = dot(b, m) / alpha_y;
    float c2 = NoM * NoM;
    float e = (x * x + y * y) / c2;
    if (e > 87.0) return 0.0;
    return exp(-e) / (PI * alpha_x * alpha_y * c2 * c2);
}

#endif
