// The metallic-roughness material and its BRDF. Twin: app/reference/material.py.
#ifndef PBS_MATERIAL_GLSL
#define PBS_MATERIAL_GLSL

// What the lighting pass knows of a surface point after decoding the G-buffer.
struct Surface {
    vec3 base_color;           // linear RGB
    float metallic;            // 0 dielectric, 1 conductor
    float perceptual_roughness;
    float f0_dielectric;       // normal-incidence reflectance when metallic = 0
};

// The metalness workflow (glTF 2.0 Appendix B; Burley 2012): one base colour serves
// as the diffuse albedo of a dielectric and as the F0 of a metal.
//   F0      = mix(f0_dielectric, base_color, metallic)
//   rho_ss  = (1 - metallic) base_color
vec3 material_F0(Surface s) {
    return mix(vec3(s.f0_dielectric), s.base_color, s.metallic);
}

vec3 material_rho_ss(Surface s) {
    return (1.0 - s.metallic) * s.base_color;
}

// alpha = r^2 (Burley 2012), with r floored at MIN_PERCEPTUAL_ROUGHNESS.
float material_alpha(Surface s) {
    float r = max(s.perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    return r * r;
}

// f(l, v) = rho_ss / pi + f_spec: Lambert diffuse plus the GGX microfacet specular.
// The diffuse term is not weighted by (1 - F) here (as in Filament and the glTF
// metallic-roughness model's Lambert lobe); the coupled form is a separate model.
vec3 brdf_standard(Surface s, vec3 n, vec3 l, vec3 v) {
    return Fd_lambert(material_rho_ss(s)) + f_spec_GGX(material_F0(s), material_alpha(s), n, l, v);
}

#endif
