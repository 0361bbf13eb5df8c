// Roughness that absorbs the normals a pixel averages (RTR4 sec. 9.13): geometric specular
// antialiasing, and LEAN's slope covariance turned into anisotropic roughness.
// Twin: app/reference/filtering.py.
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

// Olano & Baker 2010, "LEAN Mapping": the filtered normal map's slope covariance added to the
// material's own lobe, turned back into the anisotropic parameters the G-buffer stores
// (RTR4 sec. 9.8: alpha_x = alpha (1 + a) along the tangent, alpha_y = alpha (1 - a)).
// r, anisotropy a and the unit direction d (in the tangent frame (t, b)) are the material's;
// sigma = (Sxx, Syy, Sxy), the covariance of the slopes under the texel's footprint
// (app/textures/lean.py). A lobe of roughness alpha has slope variance alpha^2/2 per axis, so
// A' = alpha_x^2 d d^T + alpha_y^2 d_perp d_perp^T + 2 k Sigma; its eigenvalues (clamped to
// [0, 1]) are alpha_x'^2 >= alpha_y'^2 and its major eigenvector the new direction: the longer
// of the two closed forms ((Axx - Ayy)/2 + q, Axy) and (Axy, (Ayy - Axx)/2 + q), which never
// cancels; d itself where A' is isotropic. Returns vec4(r', a', direction'), r' =
// sqrt((alpha_x' + alpha_y')/2), a' = (alpha_x' - alpha_y')/(alpha_x' + alpha_y').
// spread: k in A' = A + 2 k Sigma, 1 for Beckmann's Gaussian slopes (variance matching),
// GGX_LEAN_SPREAD for GGX, whose slopes have infinite variance: the lobe whose central
// interval holding erf(1/sqrt 2) of its slopes is the footprint's +-sigma (the twin's
// ggx_lean_spread derives it; docs/filtering.md measures it).
// Twin: app/reference/filtering.py lean_anisotropic_roughness.
const float GGX_LEAN_SPREAD = 0.5728118642;

// The spread of the G-buffer pass's material: LEAN_GGX is defined for a GGX material's
// covariance (app/textures/lean.py lean_defines).
#if defined(LEAN_GGX)
#define LEAN_SPREAD GGX_LEAN_SPREAD
#else
#define LEAN_SPREAD 1.0
#endif

vec4 lean_anisotropic_roughness(float r, float anisotropy, vec2 d, vec3 sigma, float spread) {
    float alpha = r * r;
    float ax2 = alpha * (1.0 + anisotropy);
    float ay2 = alpha * (1.0 - anisotropy);
    ax2 *= ax2;
    ay2 *= ay2;
    vec3 s = (2.0 * spread) * sigma;
    float axx = ax2 * d.x * d.x + ay2 * d.y * d.y + s.x;
    float ayy = ax2 * d.y * d.y + ay2 * d.x * d.x + s.y;
    float axy = (ax2 - ay2) * d.x * d.y + s.z;
    float half_diff = 0.5 * (axx - ayy);
    float mean = 0.5 * (axx + ayy);
    float q = sqrt(half_diff * half_diff + axy * axy);
    float alpha_x = sqrt(clamp(mean + q, 0.0, 1.0));
    float alpha_y = sqrt(clamp(mean - q, 0.0, 1.0));
    vec2 e = half_diff >= 0.0 ? vec2(half_diff + q, axy) : vec2(axy, q - half_diff);
    float len = length(e);
    vec2 dir = len > 0.0 ? e / len : d;
    float total = alpha_x + alpha_y;
    float a = total > 0.0 ? (alpha_x - alpha_y) / total : 0.0;
    return vec4(sqrt(0.5 * total), a, dir);
}

#endif
