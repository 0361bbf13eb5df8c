// Fresnel reflectance terms. Twin: app/reference/fresnel.py.
#ifndef PBS_FRESNEL_GLSL
#define PBS_FRESNEL_GLSL

// (1 - x)^5 by squaring: two multiplies fewer than pow() and exact at x = 1.
float pow5_one_minus(float x) {
    float m = 1.0 - x;
    float m2 = m * m;
    return m2 * m2 * m;
}

// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering";
// RTR4 sec. 9.5: F = F0 + (1 - F0)(1 - (n.l)+)^5, evaluated with the micro-normal h.
vec3 F_schlick(vec3 F0, float cos_theta) {
    return F0 + (1.0 - F0) * pow5_one_minus(clamp(cos_theta, 0.0, 1.0));
}

// RTR4 sec. 9.5, the generalised Schlick approximation:
//   F = F0 + (F90 - F0)(1 - (n.l)+)^(1/p),  exponent = 1/p > 0 (p = 1/5 is Schlick).
// pow(0, e) is undefined in GLSL (pow is exp2(e log2 x)), so 0^e = 0 is written out.
vec3 F_schlick_generalized(vec3 F0, vec3 F90, float exponent, float cos_theta) {
    float m = 1.0 - clamp(cos_theta, 0.0, 1.0);
    float w = m > 0.0 ? pow(m, exponent) : 0.0;
    return F0 + (F90 - F0) * w;
}

// Fresnel 1823; Born & Wolf, "Principles of Optics", sec. 1.5.2: the unpolarised
// reflectance (R_s + R_p)/2 of a dielectric interface, eta = n2/n1 (far side over
// incident side); eta < 1 is internal reflection, total past sin(theta_c) = eta.
// With d = eta^2 - 1 and g = eta cos(theta_t) = sqrt(d + cos_i^2) (Walter et al. 2007, eq. 22):
//   r_s = (c - g)/(c + g),  r_p = (eta^2 c - g)/(eta^2 c + g).
// Precision: c - g and eta^2 c - g cancel as eta -> 1 (and c - g as theta -> 90 deg), so
// both are multiplied through by their conjugates:
//   r_s = -d / (g + c)^2,   r_p = d ((eta^2 + 1) c^2 - 1) / (eta^2 c + g)^2,
// and d = (eta - 1)(eta + 1) is exact to an ulp near eta = 1 (eta - 1 is exact there).
// Then F ~ d^2 keeps full relative precision down to eta = 1 +- 1 ulp, and eta = 1 gives
// exactly 0 (tested first: at c = 0 it would be 0/0). Near the critical angle g is the
// square root of a cancelling difference: that is the function's own infinite slope
// there (dF/dc ~ 1/g), not an artefact of this form; g^2 <= 0 returns exactly 1.
float F_dielectric(float eta, float cos_theta_i) {
    float c = clamp(cos_theta_i, 0.0, 1.0);
    float d = (eta - 1.0) * (eta + 1.0);
    if (d == 0.0) return 0.0;
    float g2 = d + c * c;
    if (g2 <= 0.0) return 1.0;
    float g = sqrt(g2);
    float e2 = eta * eta;
    float gc = g + c;
    float q = e2 * c + g;
    float rs = d / (gc * gc);
    float rp = d * ((e2 + 1.0) * c * c - 1.0) / (q * q);
    return 0.5 * (rs * rs + rp * rp);
}

// Born & Wolf, "Principles of Optics", ch. 14 (optics of metals), in the a, b form
// collected by Lagarde 2013, "Memo on Fresnel equations": with the complex relative index
// eta + i k and w = a + i b = sqrt((eta + i k)^2 - sin^2 theta) (a, b >= 0),
//   R_s = ((a - c)^2 + b^2) / ((a + c)^2 + b^2),
//   R_p = R_s ((a c - s^2)^2 + (b c)^2) / ((a c + s^2)^2 + (b c)^2),  s^2 = 1 - c^2.
// Precision, as in F_dielectric: the numerators cancel where F is small, so they are
// replaced by the angle-free products |c - w|^2 |c + w|^2 = |(eta + i k)^2 - 1|^2 and
// |w c - s^2|^2 |w c + s^2|^2 = |(eta + i k)^2 c^2 - s^2|^2; a and b are taken from the
// larger of (|w^2| +- Re w^2)/2 and a b = eta k, so neither cancels either.
// k = 0 reduces to F_dielectric (internal reflection and TIR included).
vec3 F_conductor(vec3 eta, vec3 k, float cos_theta_i) {
    float c = clamp(cos_theta_i, 0.0, 1.0);
    float c2 = c * c;
    float s2 = 1.0 - c2;
    vec3 d = (eta - 1.0) * (eta + 1.0) - k * k;  // Re(eta_c^2) - 1
    vec3 p = 2.0 * eta * k;                      // Im(eta_c^2)
    vec3 t = d + c2;                             // Re(w^2)
    vec3 m = sqrt(t * t + p * p);                // |w|^2
    vec3 big = sqrt(0.5 * (m + abs(t)));         // max(a, b)
    vec3 small = 0.5 * p / max(big, vec3(1e-30)); // min(a, b); 0 when big = 0 (then p = 0)
    vec3 a = mix(big, small, lessThan(t, vec3(0.0)));
    vec3 b = mix(small, big, lessThan(t, vec3(0.0)));
    vec3 ac = a + c;
    vec3 D = ac * ac + b * b;                    // |c + w|^2
    vec3 N = d * d + p * p;                      // |eta_c^2 - 1|^2; 0 only for eta_c = 1
    vec3 Rs = N / max(D * D, vec3(1e-30));
    vec3 acs = a * c + s2;
    vec3 bc = b * c;
    vec3 E = acs * acs + bc * bc;                // |w c + s^2|^2
    vec3 re = (d + 1.0) * c2 - s2;               // Re(eta_c^2 c^2 - s^2)
    vec3 im = p * c2;
    vec3 M = re * re + im * im;
    vec3 Rp = Rs * M / max(E * E, vec3(1e-30));
    return 0.5 * (Rs + Rp);
}

// The cosine to give Schlick's approximation (RTR4 sec. 9.5.2): the
// incident one for external reflection (eta >= 1); for internal reflection (eta < 1) the
// transmitted one, cos_t = sqrt(1 - (1 - c^2)/eta^2), which makes F_schlick(F0, cos_t)
// reciprocal (Stokes), and 0 past the critical angle, where F_schlick gives exactly 1.
// cos_t = sqrt(d + c^2)/eta with d = (eta - 1)(eta + 1): the same g as F_dielectric, so
// both switch to total internal reflection at the same inputs.
float cos_theta_schlick(float eta, float cos_theta_i) {
    float c = clamp(cos_theta_i, 0.0, 1.0);
    if (eta >= 1.0) return c;
    float g2 = (eta - 1.0) * (eta + 1.0) + c * c;
    return g2 > 0.0 ? min(sqrt(g2) / eta, 1.0) : 0.0;
}

#endif
