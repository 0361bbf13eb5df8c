// Transmission and volume (RTR4 sec. 14.5; glTF KHR_materials_transmission and
// KHR_materials_volume): the light of the scene behind a dielectric surface that is
// refracted through it, as a screen-space lookup into the opaque HDR image.
//   L_t = transmission (1 - metallic) (1 - F(n.v)) base_color T(d) L_behind
// with F the dielectric base's Schlick Fresnel (what the surface reflects it does not
// transmit), T(d) = exp(-sigma d), sigma = -ln(attenuation_color) / attenuation_distance
// (Beer-Lambert; KHR_materials_volume), and L_behind the opaque image where the ray that
// leaves the volume (transmission_ray: refracted in and out of a sphere) reaches the opaque
// surfaces, blurred by roughness through its mip chain (the glTF Sample Viewer's and
// Filament's screen-space approach; rough refraction itself: Walter et al. 2007,
// "Microfacet Models for Refraction through Rough Surfaces"). A punctual light behind the
// surface adds the transmitted GGX lobe (transmitted_light, below). The float64 twin is
// app/reference/transmission.py, same names.
#ifndef PBS_TRANSMISSION_GLSL
#define PBS_TRANSMISSION_GLSL

#include "brdf/fresnel.glsl"
#include "brdf/masking.glsl"
#include "brdf/ndf.glsl"

// The refracted direction of the view ray -v entering a medium of relative index eta
// (n2 / n1) through normal n (Snell's law, GLSL refract()'s formula); total internal
// reflection (only for eta < 1) gives the mirrored ray instead of refract()'s zero.
vec3 refracted_direction(vec3 v, vec3 n, float eta) {
    float cos_i = dot(n, v);
    float inv = 1.0 / eta;
    float k = 1.0 - inv * inv * (1.0 - cos_i * cos_i);
    if (k < 0.0) return reflect(-v, n);
    return -inv * v - (sqrt(k) - inv * cos_i) * n;
}

// A volume's light path, as through a solid sphere of diameter `thickness` that the surface
// touches at p (Filament's "solid" refraction; KHR_materials_volume gives only a thickness
// and leaves the far side's shape to the renderer): the view ray refracts in at p (index
// eta), crosses the chord, of length thickness cos(theta_t), to the far side, whose outward
// normal is n mirrored across the plane normal to the chord, n - 2 (n.t) t (the sphere's
// symmetry), and refracts out there (index 1 / eta). The second refraction bends the ray
// again towards the axis, so that beyond the sphere's focal length (n R / (2 (n - 1)) from
// its centre) what lies behind is seen inverted, as through a real ball. A thin-walled
// surface (thickness 0) leaves at p along -v, unbent.
struct TransmissionRay {
    vec3 exit;        // where the ray leaves the volume (world space)
    vec3 direction;   // its unit direction after the second refraction
};

TransmissionRay transmission_ray(vec3 p, vec3 v, vec3 n, float eta, float thickness) {
    if (thickness <= 0.0) return TransmissionRay(p, -v);
    vec3 t = refracted_direction(v, n, eta);
    float NoT = dot(n, t);
    vec3 exit = p + t * (thickness * max(-NoT, 0.0));
    vec3 n_back = n - 2.0 * NoT * t;   // outward at the exit
    return TransmissionRay(exit, refracted_direction(-t, -n_back, 1.0 / eta));
}

// KHR_materials_dispersion: the index at the three channels' wavelengths (630, 532 and
// 465 nm), n(lambda) = max(ior + (ior - 1) / V_d (523655 / lambda^2 - 1.5168), 1), with
// 1 / V_d = dispersion / 20 (the extension's formula; lambda in nm).
vec3 dispersion_iors(float ior, float dispersion) {
    vec3 lambda = vec3(630.0, 532.0, 465.0);
    vec3 spread = 523655.0 / (lambda * lambda) - 1.5168;
    return max(ior + (ior - 1.0) * dispersion / 20.0 * spread, vec3(1.0));
}

// Beer-Lambert transmittance over a path of length d: attenuation_color^(d / distance), as
// exp(-sigma d); attenuation_distance <= 0 is no attenuation (the specification's infinity).
vec3 beer_lambert(vec3 attenuation_color, float attenuation_distance, float d) {
    if (attenuation_distance <= 0.0) return vec3(1.0);
    vec3 sigma = -log(max(attenuation_color, vec3(1e-30))) / attenuation_distance;
    return exp(-sigma * d);
}

// The mip level of the opaque image read for a rough surface: the level whose texel spans
// the rough lobe's footprint on what lies behind. GGX normals tilt by about atan(alpha)
// (alpha is the median of tan(theta_m)); a thin wall's lobe is the reflection lobe mirrored
// through the surface (glTF's thin-walled BTDF), so directions spread by twice the tilt; a
// volume's refraction turns a tilt delta into delta (1 - 1/eta) (Snell's law to first
// order; Walter et al. 2007). Over the path length s to what lies behind, the footprint's
// diameter is 2 s tan(spread), in pixels times focal_px / depth_behind (focal_px =
// height / (2 tan(fov_y / 2))): LOD = log2 of it, 0 where it is under a pixel.
float transmission_lod(float perceptual_roughness, float eta, bool thin, float path,
                       float depth_behind, float focal_px) {
    float tilt = atan(perceptual_roughness * perceptual_roughness);
    float spread = thin ? 2.0 * tilt : tilt * max(1.0 - 1.0 / eta, 0.0);
    float pixels = 2.0 * path * tan(min(spread, 1.5)) * focal_px / max(depth_behind, 1e-6);
    return log2(max(pixels, 1.0));
}

// The weight of the light behind: transmission (1 - metallic) (1 - F_schlick(F0, n.v)) per
// channel, with F0 the dielectric base's (f0 specular_color).
vec3 transmission_weight(vec3 f0_dielectric, float NoV, float transmission, float metallic) {
    return transmission * (1.0 - metallic) * (1.0 - F_schlick(f0_dielectric, NoV));
}

// L_t: the light behind, tinted by the base colour and the volume's transmittance.
vec3 transmitted_radiance(vec3 behind, vec3 base_color, vec3 weight, vec3 transmittance) {
    return weight * base_color * transmittance * behind;
}

// --- punctual lights seen through the surface ---

// The transmitted lobe's roughness: alpha clamp(2 eta - 2, 0, 1) (the glTF Sample Viewer's
// applyIorToRoughness: an index of 1 does not bend, so does not spread, the light), floored
// at the BRDF's smallest alpha (MIN_PERCEPTUAL_ROUGHNESS^2) so the lobe stays finite.
float transmission_alpha(float alpha, float eta) {
    float alpha_min = MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS;
    return max(alpha * clamp(2.0 * eta - 2.0, 0.0, 1.0), alpha_min);
}

// f_t(l, v) |n.l| / (base_color T(d)) of a punctual light behind a thin surface, towards
// l (n.l < 0): KHR_materials_transmission's specular BTDF, the light mirrored through the
// surface's plane, l' = l - 2 (n.l) n, and the GGX lobe about it,
//   f_t = transmission (1 - metallic) (1 - F(v.h')) D(h') V(n.l', n.v),  h' = |l' + v|,
// times its cosine n.l' = |n.l| (the rendering equation's; the glTF Sample Viewer leaves
// the cosine out). 0 for a light in front of the surface.
vec3 transmitted_light(vec3 n, vec3 v, vec3 l, float alpha_t, vec3 f0_dielectric,
                       float transmission, float metallic) {
    float NoL = -dot(n, l);
    if (NoL <= 0.0) return vec3(0.0);
    vec3 l_mirror = l + 2.0 * NoL * n;
    vec3 h = normalize(l_mirror + v);
    float NoV = max(dot(n, v), 0.0);
    float lobe = D_GGX(n, h, alpha_t) * V_height_correlated_GGX(NoL, NoV, alpha_t) * NoL;
    return transmission_weight(f0_dielectric, clamp(dot(v, h), 0.0, 1.0), transmission,
                               metallic) * lobe;
}

#endif
