// Masking-shadowing: Smith Lambda, G1 and the joint G2. Twin: app/reference/masking.py.
#ifndef PBS_MASKING_GLSL
#define PBS_MASKING_GLSL

// Walter et al. 2007; Heitz 2014, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs", eq. 72: Lambda(s) = (sqrt(1 + alpha^2 tan^2 theta_s) - 1) / 2.
// Written with cos only: tan^2 = (1 - c^2)/c^2, so Lambda = (sqrt(c^2 + alpha^2 (1 - c^2))/c - 1)/2.
float Lambda_GGX(float cos_theta, float alpha) {
    float c2 = cos_theta * cos_theta;
    return 0.5 * (sqrt(c2 + alpha * alpha * (1.0 - c2)) / cos_theta - 1.0);
}

// Smith 1967; seed section 7: G1(m, v) = chi+(m.v) / (1 + Lambda(v)).
float G1_smith(float Lambda_v) {
    return 1.0 / (1.0 + Lambda_v);
}

// Heitz 2014 eq. 99; seed section 7, height-correlated form:
//   G2(l, v, m) = chi+(m.v) chi+(m.l) / (1 + Lambda(v) + Lambda(l)).
float G2_height_correlated_GGX(float NoL, float NoV, float alpha) {
    return 1.0 / (1.0 + Lambda_GGX(NoL, alpha) + Lambda_GGX(NoV, alpha));
}

// The same G2 already divided by 4 |n.l| |n.v| (the "visibility" V of the specular BRDF):
//   V = 0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)).
// Algebraically identical to G2/(4 n.l n.v), but with no division by the cosines, so
// it stays finite and accurate as n.l or n.v go to 0 (Heitz 2014; Lagarde 2014).
float V_height_correlated_GGX(float NoL, float NoV, float alpha) {
    float a2 = alpha * alpha;
    float lambda_v = NoL * sqrt(NoV * NoV * (1.0 - a2) + a2);
    float lambda_l = NoV * sqrt(NoL * NoL * (1.0 - a2) + a2);
    return 0.5 / (lambda_v + lambda_l);
}

#endif
