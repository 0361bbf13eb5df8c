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
// seed section 5: F = F0 + (1 - F0)(1 - (n.l)+)^5, evaluated with the micro-normal h.
vec3 F_schlick(vec3 F0, float cos_theta) {
    return F0 + (1.0 - F0) * pow5_one_minus(clamp(cos_theta, 0.0, 1.0));
}

#endif
