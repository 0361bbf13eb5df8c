// Geometric specular antialiasing: roughness that absorbs the normals a pixel averages
// (RTR4 sec. 9.13). Twin: app/reference/filtering.py.
#ifndef PBS_FILTERING_GLSL
#define PBS_FILTERING_GLSL

// Tokuyoshi & Kaplanyan 2019, "Improved Geometric Specular Antialiasing", the isotropic kernel
// for deferred shading (after Kaplanyan et al. 2016, "Filtering Distributions of Normals for
// Shading Antialiasing"):
//   variance = sigma2 (|dn/dx|^2 + |dn/dy|^2);  kernel = min(2 variance, kappa);
//   alpha2' = clamp(alpha2 + kernel, 0, 1).
// The pixel footprint's spread of normals, as a slope variance, widens the NDF: alpha^2 gains
// twice the variance (the Beckmann slope variance per axis is alpha^2/2). dndx, dndy are
// dFdx(n), dFdy(n) of the shading normal. sigma2: variance of the pixel filter in pixels^2;
// kappa: the most alpha^2 the filter may add, so that derivatives across silhouettes and UV
// seams (huge and meaningless) cannot turn a mirror into a fully rough surface. Both come
// from the scene's render settings (u_specular_aa in material/layers.glsl); the twin gives
// their defaults and sources. Precision: derivatives beyond ~1e19 overflow the dot
// products to +Inf, and min(+Inf, kappa) = kappa, the clamp the paper intends.
float alpha2_specular_aa(float alpha2, vec3 dndx, vec3 dndy, float sigma2, float kappa) {
    float variance = sigma2 * (dot(dndx, dndx) + dot(dndy, dndy));
    float kernel = min(2.0 * variance, kappa);
    return clamp(alpha2 + kernel, 0.0, 1.0);
}

// Tokuyoshi & Kaplanyan 2019 on perceptual roughness: r -> alpha^2 = r^4 ->
// alpha2_specular_aa -> r' = (alpha2')^(1/4), for a G-buffer that stores r.
float perceptual_roughness_specular_aa(float r, vec3 dndx, vec3 dndy, float sigma2,
                                       float kappa) {
    float alpha = r * r;
    return sqrt(sqrt(alpha2_specular_aa(alpha * alpha, dndx, dndy, sigma2, kappa)));
}

#endif
