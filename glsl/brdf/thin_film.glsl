// Thin-film interference (RTR4 sec. 9.11): a dielectric film of index n2 and thickness d
// between the medium (n1) and the base (n3, complex for a metal) replaces the base's
// Fresnel reflectance F by the film's (the glTF KHR_materials_iridescence arrangement).
// Twin: app/reference/thin_film.py, which also holds the spectral reference this
// approximation is measured against (docs/thin-film.md).
//
// Model: Belcour and Barla 2017, "A Practical Extension to Microfacet Theory for the
// Modeling of Varying Iridescence" (ACM TOG 36(4)). Per polarisation, Airy's reflectance
// of the two interfaces is exactly the Fourier series in the phase delta = 2 pi OPD/lambda,
//   R = C0 + 2 sum_m C_m cos(m (delta + phi)),  OPD = 2 n2 d cos(theta2),
// and each cos(m delta + m phi) is integrated against the colour-matching functions in
// closed form, the functions being fitted by Gaussians in wavenumber: a Gaussian's Fourier
// transform is a Gaussian, so the integral damps as exp(-4 pi^2 var (m OPD)^2) and a thick
// film tends to the incoherent sum C0 instead of aliasing (their anti-aliasing).
#ifndef PBS_THIN_FILM_GLSL
#define PBS_THIN_FILM_GLSL

#include "common/constants.glsl"

// Terms of the series kept (Belcour and Barla keep 3); the twin's FILM_TERMS.
#define FILM_TERMS 3
// Below this thickness (nm) the film fades in over the base's own Fresnel (F_film_selected).
#define FILM_FADE_NM 10.0

// Their Gaussian fits (x: two lobes, y, z), rescaled from metres to nanometres so that the
// OPD is in nm and no constant is near float32's limits (precision): position pos (1/nm)
// and variance var (1/nm^2) of each lobe.
const vec4 FILM_POS_NM = vec4(1.6810e-3, 2.2399e-3, 1.7953e-3, 2.2084e-3);
const vec4 FILM_VAR_NM = vec4(4.3278e-9, 4.5282e-9, 9.3046e-9, 6.6121e-9);
// Each lobe's amplitude val sqrt(2 pi var) times the XYZ -> linear sRGB matrix (IEC
// 61966-2-1, D65), each channel normalised so that OPD = 0 (a flat spectrum) gives exactly
// white: row c = lobe weights of channel c (computed by the twin, FILM_RGB).
const vec4 FILM_R = vec4(2.2759311012e+00, 4.1365201966e-01, -1.2755264037e+00, -4.1405671715e-01);
const vec4 FILM_G = vec4(-8.6528949889e-01, -1.5726695269e-01, 1.9786865720e+00, 4.3869879556e-02);
const vec4 FILM_B = vec4(5.1765574189e-02, 9.4084281819e-03, -2.2425167061e-01, 1.1630776682e+00);

// The colour-matched integral of cos(2 pi OPD/lambda + shift) is A cos(shift) - B sin(shift)
// (cos(a + b) split so that the shift may differ per channel and polarisation while the
// four lobes are evaluated once per term). A and B in linear sRGB.
void film_sensitivity(float opd_nm, out vec3 A, out vec3 B) {
    vec4 damp = exp(-4.0 * PI * PI * FILM_VAR_NM * (opd_nm * opd_nm));
    vec4 angle = (2.0 * PI * opd_nm) * FILM_POS_NM;
    vec4 a = damp * cos(angle);
    vec4 b = damp * sin(angle);
    A = vec3(dot(FILM_R, a), dot(FILM_G, a), dot(FILM_B, a));
    B = vec3(dot(FILM_R, b), dot(FILM_G, b), dot(FILM_B, b));
}

// The film -> base interface for the complex relative index eta + i k (per channel) at the
// real cosine c in the film: reflectances R and phases phi of
//   r_s = (c - w)/(c + w),  r_p = (eta_c^2 c - w)/(eta_c^2 c + w),  w = sqrt(eta_c^2 - s^2),
// Im w >= 0 (the wave decays into the base). Precision: a and b of w from the larger of
// (|w^2| +- Re w^2)/2 and a b = eta k, as F_conductor does. atan(0, 0) is undefined in
// GLSL: a phase is 0 where R is 0 (its term then has weight 0).
void film_base_interface(vec3 eta, vec3 k, float c, out vec3 Rs, out vec3 phis,
                         out vec3 Rp, out vec3 php) {
    float c2 = c * c;
    vec3 e2_re = (eta - k) * (eta + k);
    vec3 e2_im = 2.0 * eta * k;
    vec3 t = e2_re - (1.0 - c2);
    vec3 m = sqrt(t * t + e2_im * e2_im);
    vec3 big = sqrt(0.5 * (m + abs(t)));
    vec3 small = 0.5 * e2_im / max(big, vec3(1e-30));
    bvec3 neg = lessThan(t, vec3(0.0));
    vec3 w_re = mix(big, small, neg);
    vec3 w_im = mix(small, big, neg);
    // s: (c - w)/(c + w)
    vec3 n_re = c - w_re;
    vec3 n_im = -w_im;
    vec3 d_re = c + w_re;
    vec3 d_im = w_im;
    vec3 den = max(d_re * d_re + d_im * d_im, vec3(1e-30));
    vec3 r_re = (n_re * d_re + n_im * d_im) / den;
    vec3 r_im = (n_im * d_re - n_re * d_im) / den;
    Rs = r_re * r_re + r_im * r_im;
    phis = vec3(Rs.x > 0.0 ? atan(r_im.x, r_re.x) : 0.0, Rs.y > 0.0 ? atan(r_im.y, r_re.y) : 0.0,
                Rs.z > 0.0 ? atan(r_im.z, r_re.z) : 0.0);
    // p: (eta_c^2 c - w)/(eta_c^2 c + w)
    vec3 a_re = e2_re * c;
    vec3 a_im = e2_im * c;
    n_re = a_re - w_re;
    n_im = a_im - w_im;
    d_re = a_re + w_re;
    d_im = a_im + w_im;
    den = max(d_re * d_re + d_im * d_im, vec3(1e-30));
    r_re = (n_re * d_re + n_im * d_im) / den;
    r_im = (n_im * d_re - n_re * d_im) / den;
    Rp = r_re * r_re + r_im * r_im;
    php = vec3(Rp.x > 0.0 ? atan(r_im.x, r_re.x) : 0.0, Rp.y > 0.0 ? atan(r_im.y, r_re.y) : 0.0,
               Rp.z > 0.0 ? atan(r_im.z, r_re.z) : 0.0);
}

// One polarisation's series: r12 (real, medium -> film), R23 and phi23 (film -> base).
// T121 = 1 - R12, Rs = T121^2 R23/(1 - R12 R23), C0 = R12 + Rs,
// C_m = (Rs - T121) sqrt(R12 R23)^m, phi = arg(r21) + phi23 with r21 = -r12.
vec3 film_series(float r12, vec3 R23, vec3 phi23, vec3 A[FILM_TERMS], vec3 B[FILM_TERMS]) {
    float R12 = r12 * r12;
    float phi21 = r12 > 0.0 ? PI : 0.0;
    float T121 = 1.0 - R12;
    vec3 R123 = R12 * R23;
    vec3 r123 = sqrt(R123);
    vec3 Rs = T121 * T121 * R23 / max(1.0 - R123, vec3(1e-30));
    vec3 I = R12 + Rs;
    vec3 Cm = Rs - T121;
    vec3 phi = phi21 + phi23;
    for (int m = 1; m <= FILM_TERMS; ++m) {
        Cm *= r123;
        vec3 mphi = float(m) * phi;
        I += 2.0 * Cm * (A[m - 1] * cos(mphi) - B[m - 1] * sin(mphi));
    }
    return I;
}

// Belcour and Barla 2017: the reflectance of a film of relative index eta_film = n2/n1,
// absolute index film_ior = n2 (the optical path) and thickness thickness_nm over a base
// of relative index eta_base + i k_base (n3/n1, per RGB channel), at cos(theta1) =
// cos_theta; linear sRGB, clamped to [0, 1]. Total reflection at the top of a film of
// lower index gives 1. The medium -> film interface in the cancellation-free forms of
// F_dielectric (d = (eta - 1)(eta + 1), g = eta cos(theta2) = sqrt(d + c^2)):
//   r_s = -d/(c + g)^2,  r_p = d((eta^2 + 1) c^2 - 1)/(eta^2 c + g)^2.
vec3 F_thin_film(float eta_film, float film_ior, float thickness_nm, vec3 eta_base,
                 vec3 k_base, float cos_theta) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float d = (eta_film - 1.0) * (eta_film + 1.0);
    float g2 = d + c * c;
    if (g2 <= 0.0) return vec3(1.0);
    float g = sqrt(g2);
    float e2 = eta_film * eta_film;
    float gc = g + c;
    float q = e2 * c + g;
    float rs12 = -d / max(gc * gc, 1e-30);
    float rp12 = d * ((e2 + 1.0) * c * c - 1.0) / max(q * q, 1e-30);
    float cos2 = g / eta_film;
    float opd = 2.0 * film_ior * thickness_nm * cos2;
    // The base's index relative to the film's.
    float inv = 1.0 / eta_film;
    vec3 Rs23, phs23, Rp23, php23;
    film_base_interface(eta_base * inv, k_base * inv, cos2, Rs23, phs23, Rp23, php23);
    vec3 A[FILM_TERMS];
    vec3 B[FILM_TERMS];
    for (int m = 1; m <= FILM_TERMS; ++m) film_sensitivity(float(m) * opd, A[m - 1], B[m - 1]);
    vec3 total = film_series(rs12, Rs23, phs23, A, B) + film_series(rp12, Rp23, php23, A, B);
    return clamp(0.5 * total, 0.0, 1.0);
}

// The real index whose normal-incidence reflectance is F0 (clamped to 0.99: a white metal
// gets 399, not infinity): how the metalness workflow's base colour becomes the index
// under the film (k = 0, as glTF KHR_materials_iridescence does).
vec3 ior_from_f0_rgb(vec3 F0) {
    vec3 s = sqrt(clamp(F0, 0.0, 0.99));
    return (1.0 + s) / (1.0 - s);
}

#endif
