// Masking-shadowing: Smith Lambda, G1 and the joint G2. Twin: app/reference/masking.py.
#ifndef PBS_MASKING_GLSL
#define PBS_MASKING_GLSL

#include "common/constants.glsl"
#include "brdf/ndf.glsl"

// Smith's masking (RTR4 sec. 9.7): G1(m, v) = chi+(m.v) / (1 + Lambda(v)), where Lambda(v)
// is fixed by the NDF: integral of G1(m, v) D(m) (v.m)+ dm = v.n. Lambda(cos) takes the
// cosine of the direction's angle to n; it is 0 at cos = 1 and +inf at cos = 0.

float positive_infinity() {
    return uintBitsToFloat(0x7F800000u);
}

// --- GGX ---

// Walter et al. 2007; Heitz 2014, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs", eq. 72: Lambda(s) = (sqrt(1 + alpha^2 tan^2 theta_s) - 1) / 2.
// Written with cos only: tan^2 = (1 - c^2)/c^2, so Lambda = (sqrt(c^2 + alpha^2 (1 - c^2))/c - 1)/2.
// Precision: that difference cancels as c -> 1 (Lambda ~ alpha^2 (1 - c)); multiplied through
// by its conjugate it is Lambda = alpha^2 s^2 / (2 c (sqrt(c^2 + alpha^2 s^2) + c)) with
// s^2 = (1 - c)(1 + c): no cancellation, 0 at c = 1, +inf at c = 0.
float Lambda_GGX(float cos_theta, float alpha) {
    float c = cos_theta;
    float a2s2 = alpha * alpha * (1.0 - c) * (1.0 + c);
    return 0.5 * a2s2 / (c * (sqrt(c * c + a2s2) + c));
}

// Smith 1967; RTR4 sec. 9.7: G1(m, v) = chi+(m.v) / (1 + Lambda(v)).
float G1_smith(float Lambda_v) {
    return 1.0 / (1.0 + Lambda_v);
}

// Heitz 2014 eq. 99; RTR4 sec. 9.7, height-correlated form:
//   G2(l, v, m) = chi+(m.v) chi+(m.l) / (1 + Lambda(v) + Lambda(l)).
float G2_height_correlated_GGX(float NoL, float NoV, float alpha) {
    return 1.0 / (1.0 + Lambda_GGX(NoL, alpha) + Lambda_GGX(NoV, alpha));
}

// The same G2 already divided by 4 |n.l| |n.v| (the "visibility" V of the specular BRDF):
//   V = 0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)).
// Algebraically identical to G2/(4 n.l n.v), but with no division by the cosines, so
// it stays finite and accurate as n.l or n.v go to 0 (Heitz 2014; Lagarde 2014).
// The square root of one direction's term, sqrt((n.x)^2 (1 - a2) + a2): the view's is the
// same for every light (brdf/material.glsl BrdfView computes it once per point).
float V_height_correlated_GGX_root(float NoX, float a2) {
    return sqrt(NoX * NoX * (1.0 - a2) + a2);
}

// V_height_correlated_GGX with the view's root given (root_v: _root(NoV, alpha^2)).
float V_height_correlated_GGX_view(float NoL, float NoV, float alpha, float root_v) {
    float lambda_v = NoL * root_v;
    float lambda_l = NoV * V_height_correlated_GGX_root(NoL, alpha * alpha);
    return 0.5 / (lambda_v + lambda_l);
}

float V_height_correlated_GGX(float NoL, float NoV, float alpha) {
    return V_height_correlated_GGX_view(NoL, NoV, alpha,
                                        V_height_correlated_GGX_root(NoV, alpha * alpha));
}

// Hammon 2017, "PBR Diffuse Lighting for GGX+Smith Microsurfaces" (GDC): a fast fit of
// V_height_correlated_GGX, V ~ 0.5 / mix(2 n.l n.v, n.l + n.v, alpha): exact at alpha = 0 and
// alpha = 1, no square roots. Its error is measured in docs/microfacet.md.
float V_hammon_GGX(float NoL, float NoV, float alpha) {
    return 0.5 / mix(2.0 * NoL * NoV, NoL + NoV, alpha);
}

// --- Beckmann ---

// Scaled complementary error function erfcx(x) = e^(x^2) erfc(x), x >= 0 (GLSL has no erf).
// The form of Abramowitz & Stegun 7.1.26 (Hastings 1955), erfcx(x) ~ t P(t), t = 1/(1 + p x),
// with p = 0.4 and a degree-10 P fitted for this project by iteratively reweighted least
// squares on the relative error (docs/microfacet.md): 1.5e-8 relative over [0, inf) in exact
// arithmetic, a few float32 ulps (measured 3.4e-7) as evaluated here. t P(t) -> 1/(x sqrt(pi))
// as x -> inf, so erfcx keeps its relative accuracy where erfc itself underflows.
float erfcx(float x) {
    float t = 1.0 / (1.0 + 0.4 * x);
    float P = 0.225675836 + t * (0.225675866 + t * (0.207613721 + t * (0.171739295
        + t * (0.11900828 + t * (0.0839164481 + t * (-0.0468952581 + t * (0.137561515
        + t * (-0.235527337 + t * (0.140446752 + t * (-0.0292151254))))))))));
    return t * P;
}

// erfc(x) = e^(-x^2) erfcx(x), x >= 0: relative error ~ 2 x^2 ulp on top of erfcx's (the
// rounding of x^2 inside exp), so ~5e-7 at x = 3.
float erfc(float x) {
    return exp(-x * x) * erfcx(x);
}

// Beckmann 1963; Walter et al. 2007; Heitz 2014 (the exact Smith Lambda of Beckmann):
//   Lambda = (erf(a) - 1)/2 + e^(-a^2)/(2 a sqrt(pi)),  a = 1/(alpha tan theta).
// Precision: erf(a) - 1 = -erfc(a) cancels as erf -> 1, so Lambda is written with erfc:
// Lambda = e^(-a^2) (1/(a sqrt(pi)) - erfcx(a))/2. The bracket still cancels slowly as a
// grows (it is ~ 1/(2 a^3 sqrt(pi))), losing ~2 a^2 ulps: so for a >= 3 it is replaced by the
// cancellation-free continued-fraction form derived from erfc's (A&S 7.1.14):
//   Lambda = e^(-a^2) / (2 a sqrt(pi) (1 + 2 a D)),  D = a + 1/(a + (3/2)/(a + 2/(a + ...))),
// 12 levels (truncation < 1e-8 for a >= 3). For a >= 9, Lambda < 1e-38 returns 0.
float Lambda_beckmann(float cos_theta, float alpha) {
    float c = cos_theta;
    float s = sqrt((1.0 - c) * (1.0 + c));
    float a = c / (alpha * s);  // +inf at c = 1
    if (a >= 9.0) return 0.0;
    const float INV_SQRT_PI = 0.56418958354775628;
    float g = exp(-a * a);
    if (a < 3.0) return 0.5 * g * (INV_SQRT_PI / a - erfcx(a));
    float D = a;
    for (int k = 12; k >= 2; --k) D = a + 0.5 * float(k) / D;
    return 0.5 * INV_SQRT_PI * g / (a * (1.0 + 2.0 * a * D));
}

// Walter et al. 2007's rational approximation of Lambda_beckmann, in Lambda form (as in
// RTR4): (1 - 1.259 a + 0.396 a^2)/(3.535 a + 2.181 a^2) for a < 1.6, else 0. Its masking-
// integral error reaches 3.1e-3 (docs/microfacet.md).
float Lambda_beckmann_rational(float cos_theta, float alpha) {
    float c = cos_theta;
    float a = c / (alpha * sqrt((1.0 - c) * (1.0 + c)));
    if (a >= 1.6) return 0.0;
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
}

// --- Lambda of any isotropic NDF by quadrature ---

// Gauss-Legendre rules on [0, 1] (nodes, weights), 8 and 12 points.
const float GL8_X[8] = float[8](0.0198550718, 0.101666761, 0.237233795, 0.408282679,
    0.591717321, 0.762766205, 0.898333239, 0.980144928);
const float GL8_W[8] = float[8](0.0506142681, 0.111190517, 0.156853323, 0.181341892,
    0.181341892, 0.156853323, 0.111190517, 0.0506142681);
const float GL12_X[12] = float[12](0.00921968288, 0.0479413718, 0.115048663, 0.206341023,
    0.316084251, 0.437383296, 0.562616704, 0.683915749, 0.793658977, 0.884951337,
    0.952058628, 0.990780317);
const float GL12_W[12] = float[12](0.0235876682, 0.053469663, 0.0800391643, 0.101583713,
    0.116746268, 0.124573523, 0.124573523, 0.116746268, 0.101583713, 0.0800391643,
    0.053469663, 0.0235876682);

// Gamma(x + 1/2) / Gamma(x) for x >= 1 (GLSL has no lgamma): shifted up to x >= 8 by
// Gamma(x + 1/2)/Gamma(x) = x/(x + 1/2) Gamma(x + 3/2)/Gamma(x + 1), then the asymptotic
// series sqrt(x) (1 - 1/(8x) + 1/(128x^2) + 5/(1024x^3) - 21/(32768x^4) - 399/(262144x^5))
// (DLMF 5.11.13 with a = 1/2, b = 0), truncation < 2e-9 at x >= 8.
float gamma_ratio_half(float x) {
    float f = 1.0;
    for (int i = 0; i < 8; ++i) {
        if (x >= 8.0) break;
        f *= x / (x + 0.5);
        x += 1.0;
    }
    float r = 1.0 / x;
    float s = 1.0 + r * (-1.0 / 8.0 + r * (1.0 / 128.0 + r * (5.0 / 1024.0
        + r * (-21.0 / 32768.0 + r * (-399.0 / 262144.0)))));
    return f * sqrt(x) * s;
}

// Blinn-Phong's exact Smith Lambda (derived in docs/microfacet.md). Its slope distribution
// D cos^4 = (alpha_p + 2)/(2 pi) (1 + tan^2)^(-(alpha_p + 4)/2) is a bivariate Student t with
// nu = alpha_p + 2 = 2/alpha^2 degrees of freedom (Ribardiere et al. 2017, "STD"), and
// Smith's Lambda = (1/mu) integral_mu^inf (q - mu) P2(q) dq (Heitz 2014; mu = cot theta,
// P2 the slope marginal) reduces to
//   Lambda = R(nu)/((nu - 1) c) integral_c^1 (1 - c^2/x^2)^(nu/2 - 1) dx,  c = cos(theta),
//   R(nu) = Gamma((nu + 1)/2) / (sqrt(pi) Gamma(nu/2)),
// which is GGX's (1/c - 1)/2 at alpha = 1 (nu = 2) and Beckmann's Lambda as alpha -> 0.
// (Walter et al. 2007 reuse Beckmann's Lambda instead: error up to 0.75 at alpha = 1.)
// Quadrature: x = c e^u, u = ln(1/c) s^k, k = max(1, 4/nu) (the power removes the
// (x - c)^(nu/2 - 1) end-point singularity for nu < 4), 12-point Gauss-Legendre in s.
// Precision: nu/2 reaches 2.5e5, so ln(1 - c^2/x^2) = ln(1 - e^(-2u)) needs absolute accuracy
// far below log()'s near 1 (llvmpipe: 9e-8): it is log_one_minus(e^(-2u)) where e^(-2u) < 1/4,
// else ln(2u E(-2u)) (1 - e^(-2u) = 2u E(-2u) without cancellation); ln(1/c) likewise,
// through log_one_minus(1 - c) for c >= 1/2.
// Masking-integral error < 1e-5 for theta <= 89 degrees (docs/microfacet.md).
float Lambda_blinn_phong(float cos_theta, float alpha) {
    float c = cos_theta;
    if (c >= 1.0) return 0.0;
    if (c <= 0.0) return positive_infinity();
    float nu = 2.0 / (alpha * alpha);
    float Y = c < 0.5 ? -log(c) : -log_one_minus(1.0 - c);  // ln(1/c); 1 - c exact here
    float k = max(1.0, 4.0 / nu);
    float sum = 0.0;
    for (int i = 0; i < 12; ++i) {
        float sk = pow(GL12_X[i], k);
        float u = Y * sk;
        float e2 = exp(-2.0 * u);
        float ln_base = e2 < 0.25 ? log_one_minus(e2) : log(2.0 * u * expm1_over_x(-2.0 * u));
        sum += GL12_W[i] * exp((0.5 * nu - 1.0) * ln_base + u) * sk / GL12_X[i];
    }
    const float INV_SQRT_PI = 0.56418958354775628;
    return gamma_ratio_half(0.5 * nu) * INV_SQRT_PI / (nu - 1.0) * Y * k * sum;
}

// atan(x) for x >= 0 (+inf gives pi/2) to ~1e-7 absolute. llvmpipe's built-in atan is off by
// up to 3.5e-6 near x = 1, which smith_kernel's x - atan(x) would turn into 1e-4 relative.
// Cody & Waite's reduction: x > 1 -> pi/2 - atan(1/x); y > 2 - sqrt(3) ->
// pi/6 + atan((sqrt(3) y - 1)/(sqrt(3) + y)); then |z| <= 0.268 and atan's odd series
// through z^13 (truncation < 1e-9).
float atan_accurate(float x) {
    bool invert = x > 1.0;
    float y = invert ? 1.0 / x : x;
    float base = 0.0;
    if (y > 0.26794919) {
        y = (1.7320508 * y - 1.0) / (1.7320508 + y);
        base = PI / 6.0;
    }
    float y2 = y * y;
    float r = base + y * (1.0 - y2 * (1.0 / 3.0 - y2 * (1.0 / 5.0 - y2 * (1.0 / 7.0
        - y2 * (1.0 / 9.0 - y2 * (1.0 / 11.0 - y2 * (1.0 / 13.0)))))));
    return invert ? 0.5 * PI - r : r;
}

// The angular kernel of Lambda for an isotropic NDF in the variables of Lambda_GTR:
//   K(psi) = sin(psi) (sin(psi) - kappa cos(psi) atan(tan(psi)/kappa))
//          = kappa sin(psi) cos(psi) (x - atan x),  x = tan(psi)/kappa,
// taking sin(psi) and cos(psi). Precision: x - atan(x) ~ x^3/3 cancels for small x, so
// x < 1/2 sums its series through x^25 (truncation < 7e-9 relative); above, the cancellation
// costs at most x/(x - atan x) <= 14 ulps plus atan_accurate's 1.4e-7 absolute: 2e-6
// relative at worst (measured 1.6e-6, tests/test_microfacet.py).
float smith_kernel(float sin_psi, float cos_psi, float kappa) {
    float kc = kappa * cos_psi;
    if (sin_psi < 0.5 * kc) {
        float x = sin_psi / kc;
        float x2 = x * x;
        float series = 1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 * (1.0 / 9.0
            - x2 * (1.0 / 11.0 - x2 * (1.0 / 13.0 - x2 * (1.0 / 15.0 - x2 * (1.0 / 17.0
            - x2 * (1.0 / 19.0 - x2 * (1.0 / 21.0 - x2 * (1.0 / 23.0 - x2 * (1.0 / 25.0)))))))))));
        return kc * sin_psi * x * x2 * series;
    }
    return sin_psi * (sin_psi - kc * atan_accurate(sin_psi / kc));
}

// Smith Lambda of Burley 2012's GTR NDF (derived in docs/microfacet.md). Burley pairs GTR
// with GGX's Lambda, exact only at gamma = 2 or alpha = 1 (masking-integral error up to 18 at
// gamma = 0.5, 5 at gamma = 1, 0.75 at gamma = 10). In polar slope coordinates Smith's
// marginal integral becomes a
// single integral with a closed-form kernel; with r^2 = cot^2 theta + (B tan psi/sin theta)^2,
//   Lambda = 2 D(n) (alpha^2/B^2)^gamma sin^2(theta) B^3 / cos(theta)
//            * integral_0^(pi/2) (cos^2 psi + B^2 sin^2 psi)^(gamma - 2) K(psi) dpsi,
//   B^2 = alpha^2 sin^2 theta + cos^2 theta,  kappa = cos(theta)/B,  D(n) = gtr_peak.
// Quadrature: 8-point Gauss-Legendre on psi in [0, pi/4]; on [pi/4, pi/2] the factor
// (sin^2 phi + B^2 cos^2 phi)^(gamma - 2), phi = pi/2 - psi, changes on the scale tan phi ~ B,
// so tan(phi) = B sinh(y), y in [0, asinh(1/B)], 8 points. Masking-integral error < 2e-5
// for gamma in [0.5, 10], theta <= 89 degrees (docs/microfacet.md).
float Lambda_GTR(float cos_theta, float alpha, float gamma) {
    float c = cos_theta;
    if (c >= 1.0) return 0.0;
    if (c <= 0.0) return positive_infinity();
    float s2 = (1.0 - c) * (1.0 + c);
    float a2 = alpha * alpha;
    float B2 = a2 * s2 + c * c;
    float B = sqrt(B2);
    float kappa = c / B;
    const float QUARTER_PI = 0.78539816339744831;
    float I_A = 0.0;
    for (int i = 0; i < 8; ++i) {
        float psi = QUARTER_PI * GL8_X[i];
        float sp = sin(psi);
        float cp = cos(psi);
        I_A += GL8_W[i] * smith_kernel(sp, cp, kappa) * pow(cp * cp + B2 * sp * sp, gamma - 2.0);
    }
    float Y = log(1.0 / B + sqrt(1.0 / B2 + 1.0));  // asinh(1/B)
    float I_B = 0.0;
    for (int i = 0; i < 8; ++i) {
        float y = Y * GL8_X[i];
        float e = exp(y);
        float sh = 0.5 * y * expm1_over_x(y) * (1.0 + 1.0 / e);  // sinh(y), no cancellation
        float ch = 0.5 * (e + 1.0 / e);
        float q = 1.0 + B2 * sh * sh;
        float rq = inversesqrt(q);
        float w = pow(B2 * ch * ch / q, gamma - 2.0) * B * ch / q;
        I_B += GL8_W[i] * smith_kernel(rq, B * sh * rq, kappa) * w;
    }
    float scale = 2.0 * gtr_peak(alpha, gamma) * pow(a2 / B2, gamma) * s2 * B2 * B / c;
    return scale * (QUARTER_PI * I_A + Y * I_B);
}

// --- anisotropy and the azimuth between l and v ---

// Heitz 2014 eq. 80: the roughness an anisotropic NDF (alpha_x along t, alpha_y along b)
// shows to Smith's masking along direction s: sqrt(cos^2(phi) ax^2 + sin^2(phi) ay^2), phi
// the azimuth of s in the (t, b) frame; Lambda_GGX(n.s, alpha_in_direction(...)) is then
// the exact Lambda of D_GGX_aniso (and likewise for Beckmann). The projections are scaled
// by their larger one first, so no square underflows; s parallel to n (no azimuth, and
// Lambda = 0 there) returns the RMS sqrt((ax^2 + ay^2)/2).
float alpha_in_direction(vec3 t, vec3 b, vec3 s, float alpha_x, float alpha_y) {
    float x = dot(t, s);
    float y = dot(b, s);
    float r = max(abs(x), abs(y));
    if (r <= 0.0) return sqrt(0.5 * (alpha_x * alpha_x + alpha_y * alpha_y));
    x /= r;
    y /= r;
    return sqrt((x * x * alpha_x * alpha_x + y * y * alpha_y * alpha_y) / (x * x + y * y));
}

// The azimuth phi in [0, pi] between l and v about n (the angle between their projections
// on the tangent plane). n x l and n x v are those projections turned by 90 degrees about n,
// so phi = atan(|(n x l) x (n x v)|, (n x l).(n x v)): accurate at every angle, unlike acos.
// Either direction within 1e-4 rad of n (|n x l|^2 < 1e-8) has no meaningful azimuth in
// float32 (its projection is rounding): phi = 0 there.
float azimuth_difference(vec3 n, vec3 l, vec3 v) {
    vec3 pl = cross(n, l);
    vec3 pv = cross(n, v);
    if (dot(pl, pl) < 1e-8 || dot(pv, pv) < 1e-8) return 0.0;
    return atan(length(cross(pl, pv)), dot(pl, pv));
}

// Ashikhmin et al. 2000 (RTR4 sec. 9.7): lambda(phi) = 1 - e^(-7.3 phi^2), written as
// x E(-x), x = 7.3 phi^2, so it keeps its relative precision at small phi.
float lambda_phi_exp(float phi) {
    float x = 7.3 * phi * phi;
    return x * expm1_over_x(-x);
}

// van Ginneken et al. 1998 (RTR4 sec. 9.7): lambda(phi) = 4.41 phi / (4.41 phi + 1).
float lambda_phi_rational(float phi) {
    return 4.41 * phi / (4.41 * phi + 1.0);
}

// --- the four joint masking-shadowing forms of RTR4 sec. 9.7 ---
// They take Lambda(v) and Lambda(l); the chi+(m.v) chi+(m.l) factors are the caller's (it
// passes m = h, where m.l and m.v are > 0). Lambda = +inf (grazing) gives G = 0.

// Separable (Walter et al. 2007): G2 = G1(v) G1(l).
float G2_separable(float Lambda_v, float Lambda_l) {
    return G1_smith(Lambda_v) * G1_smith(Lambda_l);
}

// Height-correlated (Heitz 2014 eq. 99): G2 = 1 / (1 + Lambda(v) + Lambda(l)).
float G2_height_correlated(float Lambda_v, float Lambda_l) {
    return 1.0 / (1.0 + Lambda_v + Lambda_l);
}

// Direction-correlated (Ashikhmin et al. 2000; RTR4 sec. 9.7): with lambda = lambda(phi),
//   G2 = lambda G1(v) G1(l) + (1 - lambda) min(G1(v), G1(l)).
float G2_direction_correlated(float Lambda_v, float Lambda_l, float lambda_phi) {
    float g_v = G1_smith(Lambda_v);
    float g_l = G1_smith(Lambda_l);
    return mix(min(g_v, g_l), g_v * g_l, lambda_phi);
}

// Height-direction-correlated (Ross et al. 2005; Heitz 2014; RTR4 sec. 9.7):
//   G2 = 1 / (1 + max(Lambda(v), Lambda(l)) + lambda min(Lambda(v), Lambda(l))).
// lambda = 0 (phi = 0) drops the min term outright, so two grazing Lambdas = +inf give 0,
// not 0 * inf = NaN.
float G2_height_direction_correlated(float Lambda_v, float Lambda_l, float lambda_phi) {
    float low = lambda_phi > 0.0 ? lambda_phi * min(Lambda_v, Lambda_l) : 0.0;
    return 1.0 / (1.0 + max(Lambda_v, Lambda_l) + low);
}

#endif
