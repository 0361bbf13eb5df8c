// Image-based lighting by the split sum (docs/ibl.md): the environment's light reflected
// towards v, added once per pixel by the lighting pass where ENVIRONMENT_IBL.
// Twin: app/reference/ibl.py split_sum_radiance (with the exact prefiltered radiance).
//   L_o ~ rho_ss E(n) / pi                                     (SH9 irradiance)
//       + L_pre(R, r) (F0 A(n.v, r) + B(n.v, r))                (Karis 2013's split sum)
//       + colour (1 - E(n.v)) E(n) / pi                          (Kulla-Conty, MULTISCATTER)
// The standard model's terms only: other NDFs, Fresnel and diffuse models and the coat
// get this same approximation (RTR4 sec. 10.5.2); a sheen layer adds its own split sum
// (brdf/sheen.glsl sheen_environment); anisotropy bends the normal the map is
// read about (anisotropic_bent_normal); a thin film's Fresnel replaces F0 A + B by
// F_film(n.v) (A + B) (ibl_radiance).
#ifndef PBS_LIGHTS_IBL_GLSL
#define PBS_LIGHTS_IBL_GLSL

#include "common/constants.glsl"
#include "brdf/material.glsl"
#include "brdf/multiscatter.glsl"
#include "env/equirect.glsl"

#if ENVIRONMENT_IBL

// The GGX-prefiltered environment, one cube map per roughness r_k = k / (ENV_LEVELS - 1)
// (moderngl writes only level 0 of a cube map, so the levels are separate textures and
// the roughness between two of them is a linear blend, as a mip chain's trilinear filter).
#if ENV_LEVELS != 6
#error "ibl.glsl samples exactly 6 prefiltered levels (app/render/ibl.py ENV_LEVELS)"
#endif
uniform samplerCube u_env_level0;
uniform samplerCube u_env_level1;
uniform samplerCube u_env_level2;
uniform samplerCube u_env_level3;
uniform samplerCube u_env_level4;
uniform samplerCube u_env_level5;
uniform sampler2D u_dfg_table;       // RG32F (A, B) on the Kulla-Conty table's grids
uniform vec3 u_env_sh[9];            // irradiance SH9 in the world frame, times intensity
uniform float u_env_rotation;        // radians about +Y
uniform float u_env_intensity;

// E(n) = Ramamoorthi & Hanrahan 2001, eq. 13, with their constants c1..c5.
vec3 sh9_irradiance(vec3 n) {
    const float c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708;
    vec3 L[9] = u_env_sh;
    return c1 * L[8] * (n.x * n.x - n.y * n.y) + c3 * L[6] * n.z * n.z + c4 * L[0]
         - c5 * L[6]
         + 2.0 * c1 * (L[4] * n.x * n.y + L[7] * n.x * n.z + L[5] * n.y * n.z)
         + 2.0 * c2 * (L[3] * n.x + L[1] * n.y + L[2] * n.z);
}

// (A, B) at (n.v, r): the hardware's bilinear filter at the texel-centred coordinates of
// the Kulla-Conty grids (sqrt(sqrt(mu)), sqrt((r - floor) / (1 - floor))). Precision:
// GPU filters weigh texels with ~8-bit fractions, up to 2e-3 of a cell's difference
// (the ms table avoids it; here it is far below the split sum's own error).
vec2 dfg_lookup(float mu, float perceptual_roughness) {
    vec2 size = vec2(textureSize(u_dfg_table, 0));
    float r = clamp(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    vec2 coord = vec2(sqrt(sqrt(clamp(mu, 0.0, 1.0))),
                      sqrt((r - MIN_PERCEPTUAL_ROUGHNESS) / (1.0 - MIN_PERCEPTUAL_ROUGHNESS)));
    return texture(u_dfg_table, (coord * (size - 1.0) + 0.5) / size).rg;
}

vec3 env_level(int k, vec3 d) {
    if (k == 0) return textureLod(u_env_level0, d, 0.0).rgb;
    if (k == 1) return textureLod(u_env_level1, d, 0.0).rgb;
    if (k == 2) return textureLod(u_env_level2, d, 0.0).rgb;
    if (k == 3) return textureLod(u_env_level3, d, 0.0).rgb;
    if (k == 4) return textureLod(u_env_level4, d, 0.0).rgb;
    return textureLod(u_env_level5, d, 0.0).rgb;
}

// L_pre(R, r): the two levels around r, blended linearly in r.
vec3 prefiltered_radiance(vec3 R, float perceptual_roughness) {
    float x = perceptual_roughness * float(ENV_LEVELS - 1);
    int k = min(int(x), ENV_LEVELS - 2);
    vec3 d = env_map_direction(R, u_env_rotation);
    return mix(env_level(k, d), env_level(k + 1, d), x - float(k));
}

// The direction to read the prefiltered map along: R turned towards n as roughness grows,
// where the true lobe peaks at grazing view (Lagarde & de Rousiers 2014, "Moving Frostbite
// to Physically Based Rendering", sec. 4.9.3, listing 22; fitted for GGX with correlated
// Smith G). alpha = r^2. Twin: app/reference/ibl.py specular_dominant_direction.
vec3 specular_dominant_direction(vec3 n, vec3 R, float alpha) {
    float s = 1.0 - alpha;
    return normalize(mix(n, R, s * (sqrt(s) + alpha)));
}

// The same turn made to follow the view: the lerp factor scaled by
// (1 - 0.87 alpha^0.7 (1 - n.v)^1.6), a fit (made here, docs/ibl.md) of the centroid of the
// GGX lobe f (n.l) with height-correlated G2, which bends further towards n at grazing
// view than the view-independent fit. Compiled only where IBL_VIEW_DEPENDENT_DIRECTION
// (the measurement of docs/ibl.md). Twin: app/reference/ibl.py.
vec3 specular_centroid_direction(vec3 n, vec3 R, float alpha, float NoV) {
    float s = 1.0 - alpha;
    float t = s * (sqrt(s) + alpha) * (1.0 - 0.87 * pow(alpha, 0.7) * pow(1.0 - NoV, 1.6));
    return normalize(mix(n, R, t));
}

// The normal an anisotropic surface reflects the isotropic map about: n bent towards v
// with its component along the smoother direction removed (the bitangent for a >= 0,
// where alpha_x = alpha (1 + a) along t is the rougher), by |a| min(5 alpha, 1): the bent
// reflection vector (Revie 2011, GPU Pro 2; McAuley 2015, "Rendering the World of Far Cry
// 4"), as Filament's documentation gives it. Twin: app/reference/ibl.py.
vec3 anisotropic_bent_normal(vec3 n, vec3 t, vec3 v, float anisotropy, float alpha) {
    vec3 tn = orthonormal_tangent(n, t);
    vec3 d = anisotropy >= 0.0 ? cross(n, tn) : tn;
    vec3 towards_v = v - dot(v, d) * d;
    float bend = abs(anisotropy) * min(5.0 * alpha, 1.0);
    return normalize(mix(n, towards_v, bend));
}

// The split sum at the point sp (its surface, n, t and v; the standard model's terms).
vec3 ibl_radiance(ShadingPoint sp) {
    Surface s = sp.s;
    vec3 n = sp.n;
    vec3 t = sp.t;
    vec3 v = sp.v;
    float NoV = clamp(dot(n, v), MIN_N_DOT_V, 1.0);
    float r = clamp(s.perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    vec3 nb = n;
    if (ANISOTROPIC != 0) nb = anisotropic_bent_normal(n, t, v, s.anisotropy, r * r);
    vec3 R = reflect(-v, nb);
#if defined(IBL_VIEW_DEPENDENT_DIRECTION)  // measured against the default (docs/ibl.md)
    R = specular_centroid_direction(n, R, r * r, NoV);
#elif !defined(IBL_MIRROR_DIRECTION)  // defined only to measure the correction
    R = specular_dominant_direction(n, R, r * r);
#endif
    vec3 E_n = max(sh9_irradiance(n), vec3(0.0));  // SH ringing can dip below 0
    vec3 F0 = material_F0(s, sp.params);
    vec2 AB = dfg_lookup(NoV, r);
    vec3 pre = u_env_intensity * prefiltered_radiance(R, r);
    vec3 scale = F0 * AB.x + AB.y;   // the base's Schlick F over the lobe
#if UBER_MODELS || THIN_FILM
    // A thin film (RTR4 sec. 9.11; glTF KHR_materials_iridescence): its Fresnel is not
    // Schlick's, so no scale and bias carry it; it is taken at n.v, the lobe's own
    // direction (for the mirror direction l.h = n.v), times the lobe's albedo A + B, and
    // mixed over the base's as F_film_selected mixes the two (strength, fade-in).
    if (THIN_FILM != 0) {
        float albedo = max(AB.x + AB.y, 1e-6);
        scale = F_film_selected(sp, NoV, scale / albedo) * albedo;
    }
#endif
    vec3 spec = pre * scale;
#if MULTISCATTER
    vec3 F_avg = F0 + (1.0 - F0) / 21.0;
    float E_avg = ms_E_avg(r);
    vec3 colour = F_avg * F_avg * E_avg / (1.0 - F_avg * (1.0 - E_avg));
    spec += colour * ms_loss(NoV, r) * E_n * INV_PI;
#endif
    vec3 diffuse = material_rho_ss(s) * E_n * INV_PI;
#if UBER_MODELS || SHEEN_MODEL != SHEEN_NONE
    // a sheen layer over the base (brdf/sheen.glsl sheen_environment; docs/cloth.md)
    if (SHEEN_MODEL != SHEEN_NONE) {
        sheen_environment(sp.params.sheen_color, sp.params.sheen_roughness, NoV, n, u_env_sh,
                          diffuse, spec);
    }
#endif
    // the reflections render.terms keeps, as for lights (brdf/material.glsl)
    return selected_terms(diffuse, spec);
}

#endif  // ENVIRONMENT_IBL

#endif
