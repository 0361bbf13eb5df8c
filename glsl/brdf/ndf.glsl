// Normal distribution functions D(m). Twin: app/reference/ndf.py.
#ifndef PBS_NDF_GLSL
#define PBS_NDF_GLSL

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (GGX);
// Trowbridge & Reitz 1975. Seed section 8:
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

#endif
