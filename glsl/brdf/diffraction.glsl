// Reflection from a periodic grating (RTR4 sec. 9.11, diffraction): a surface whose height
// varies with period d across its grooves (a compact disc) sends light into orders m that
// obey the grating equation l_t + v_t = (m lambda / d) g (tangential parts; Stam 1999,
// "Diffraction Shaders"). Twin: app/reference/diffraction.py, which also holds the spectral
// reference this sampling is measured against (docs/diffraction.md).
//
// Each order m != 0 is the material's lobe f moved in direction-cosine space (Harvey et
// al. 1999, "Diffracted radiance", Appl. Opt. 38(31)): (f(l, v'_m) + f(l'_m, v)) / 2, x'_m
// being x with its tangential part moved by -m lambda/d g; the efficiency is that of a
// thin sinusoidal phase grating (Goodman, "Introduction to Fourier Optics", 3rd ed., sec.
// 4.4.3): eta_m = J_m(a)^2, a = pi depth (n.l + n.v) / lambda. The composition is in
// brdf/material.glsl (f_spec_grating_selected).
#ifndef PBS_DIFFRACTION_GLSL
#define PBS_DIFFRACTION_GLSL

#include "common/constants.glsl"

// Orders kept on each side, terms of the Bessel series, wavelength samples: the twin's.
#define GRATING_ORDERS 3
#define GRATING_BESSEL_TERMS 12
#define GRATING_SAMPLES 16

// 16 bands of 25 nm over 380-780 nm, sampled at their centres 392.5 + 25 j nm; each band's
// weight is the linear sRGB of its CIE 1931 5 nm samples (the twin's GRATING_WEIGHTS,
// computed by thin_film.spectrum_to_rgb); they sum to (1, 1, 1), so a flat spectrum is white.
// A narrow order is seen as 16 discrete lines of colour: the aliasing docs/diffraction.md
// measures against the 5 nm reference.
const vec3 GRATING_WEIGHTS[GRATING_SAMPLES] = vec3[GRATING_SAMPLES](
    vec3(9.6920317987e-04, -1.0588333753e-03, 7.7572907202e-03),
    vec3(1.5233809259e-02, -1.7315418874e-02, 1.3044609281e-01),
    vec3(3.8996788501e-02, -5.0593669195e-02, 4.5579493441e-01),
    vec3(-1.3013235622e-02, -6.7068544249e-03, 3.9514363604e-01),
    vec3(-8.8504994616e-02, 9.6986777672e-02, 1.2619957155e-01),
    vec3(-1.6546004398e-01, 2.7076069647e-01, 2.4934975773e-03),
    vec3(-9.7558123620e-02, 3.6533506055e-01, -3.8978941671e-02),
    vec3(1.3726180664e-01, 2.8604531551e-01, -4.0252996408e-02),
    vec3(4.0917014254e-01, 1.0786938821e-01, -2.4829600312e-02),
    vec3(4.4582252340e-01, -1.4784800856e-02, -1.0009341461e-02),
    vec3(2.3263735390e-01, -2.5361977661e-02, -2.9492046686e-03),
    vec3(6.8063267602e-02, -8.9279970074e-03, -6.6727924489e-04),
    vec3(1.3503226210e-02, -1.8503034915e-03, -1.2203691139e-04),
    vec3(2.3943236376e-03, -3.3051988507e-04, -2.1320506741e-05),
    vec3(4.1070939519e-04, -5.6709127248e-05, -3.6554351147e-06),
    vec3(7.3243578844e-05, -1.0154510887e-05, -6.4648107958e-07)
);

float grating_wavelength(int j) {
    return 392.5 + 25.0 * float(j);
}

// J_m(x) for 0 <= m by its power series sum_k (-1)^k (x/2)^(2k+m) / (k! (k+m)!), cut at
// GRATING_BESSEL_TERMS terms (x <= 5 with depth <= 300 nm: the cut term is < 1e-8).
float grating_bessel_J(int m, float x) {
    float half_x = 0.5 * x;
    float term = 1.0;
    for (int i = 1; i <= m; ++i) term *= half_x / float(i);
    float q = -half_x * half_x;
    float total = term;
    for (int k = 1; k < GRATING_BESSEL_TERMS; ++k) {
        term *= q / float(k * (k + m));
        total += term;
    }
    return total;
}

// eta_m = J_|m|(a)^2, a = pi depth (n.l + n.v) / lambda.
float grating_efficiency(int m, float depth_nm, float lambda_nm, float NoL, float NoV) {
    float a = PI * depth_nm * (NoL + NoV) / lambda_nm;
    float j = grating_bessel_J(abs(m), a);
    return j * j;
}

// d with its tangential part moved by -shift g and its normal part rebuilt; ok is false
// where the moved part is at least 1 long (an evanescent order).
vec3 grating_shifted(vec3 d, vec3 n, vec3 g, float shift, out bool ok) {
    vec3 dt = d - n * dot(n, d) - shift * g;
    float c2 = 1.0 - dot(dt, dt);
    ok = c2 > 0.0;
    return dt + n * sqrt(max(c2, 0.0));
}

#endif
