// The metallic-roughness material and its BRDF f(l, v) under the selected model.
// Twin: app/reference/material.py.
#ifndef PBS_MATERIAL_GLSL
#define PBS_MATERIAL_GLSL

#include "common/constants.glsl"
#include "brdf/model.glsl"
#include "brdf/fresnel.glsl"
#include "brdf/masking.glsl"
#include "brdf/diffuse.glsl"
#include "brdf/multiscatter.glsl"
#include "brdf/specular.glsl"
#include "brdf/thin_film.glsl"
#include "brdf/sheen.glsl"
#include "brdf/clearcoat.glsl"
#include "brdf/diffraction.glsl"
#include "brdf/cloth.glsl"
#include "brdf/fiber.glsl"

// What the lighting pass knows of a surface point after decoding the G-buffer.
struct Surface {
    vec3 base_color;           // linear RGB
    float metallic;            // 0 dielectric, 1 conductor
    float perceptual_roughness;
    float f0_dielectric;       // normal-incidence reflectance when metallic = 0
    float anisotropy;          // -1..1: alpha_x = alpha (1 + a), alpha_y = alpha (1 - a)
};

// One point being shaded: everything the composition layer (this file's BRDF and the
// lights, environments and passes above it) needs of it, passed whole, so that every
// function there takes the same inputs and a new one is one more field (Filament's
// PixelParams, the glTF Sample Viewer's MaterialInfo). The terms of brdf/ (D, G, F, the
// lobes) take the few numbers they use. The lighting pass decodes it from the
// G-buffer (gbuffer/decode.glsl), the forward pass builds it from a fragment. A value:
// a function that changes a field (the clear coat's base, refracted v) changes its copy.
// Twin: app/reference/material.py ShadingPoint.
struct ShadingPoint {
    Surface s;            // sanitised (sanitize_surface)
    ModelParams params;   // the material's row of the table (brdf/model.glsl)
    vec3 n;               // unit shading normal, sanitised (v where it was lost)
    vec3 nc;              // unit clear-coat normal (n where the coat has none of its own)
    vec3 t;               // tangent as stored; orthonormal_tangent takes it against n
    vec3 v;               // unit, from the point towards the eye
    vec3 position;        // world position: the lights and shadows (none in a BRDF probe)
};

// --- sanitising what a G-buffer texel delivers ---
// Textures can hold NaN or Inf (a float texture, a degenerate mesh normal normalize(0) that
// the G-buffer pass encodes as is) and out-of-range values (an RGBA16F channel holds up to
// 65504); one NaN in a Surface field makes every light's f(l, v) NaN, and the HDR sum with it.
// The lighting pass maps each field into its valid range before shading:
//   s = sanitize_surface(s); n = sanitize_direction(n, v);
// Finite values are clamped to the range; NaN and +-Inf become the field's fallback.

// True unless x is NaN or +-Inf, read from the exponent bits: a compiler that assumes finite
// arithmetic may fold isnan(), isinf() and comparisons with NaN away, but not integer tests.
bool is_finite(float x) {
    return (floatBitsToUint(x) & 0x7F800000u) != 0x7F800000u;
}

// x clamped to [lo, hi]; fallback where x is NaN or +-Inf.
float sanitize_value(float x, float lo, float hi, float fallback) {
    return is_finite(x) ? clamp(x, lo, hi) : fallback;
}

// Valid ranges, and the fallback for a non-finite value:
//   base_color [0, 1] (fallback 0: black adds no light), metallic [0, 1] (0),
//   perceptual_roughness [0, 1] (1: the flattest lobe, so a bad texel cannot become a
//   firefly), f0_dielectric [0, 1] (0.04, the default dielectric), anisotropy [-1, 1] (0).
Surface sanitize_surface(Surface s) {
    vec3 c = vec3(sanitize_value(s.base_color.r, 0.0, 1.0, 0.0),
                  sanitize_value(s.base_color.g, 0.0, 1.0, 0.0),
                  sanitize_value(s.base_color.b, 0.0, 1.0, 0.0));
    return Surface(c, sanitize_value(s.metallic, 0.0, 1.0, 0.0),
                   sanitize_value(s.perceptual_roughness, 0.0, 1.0, 1.0),
                   sanitize_value(s.f0_dielectric, 0.0, 1.0, 0.04),
                   sanitize_value(s.anisotropy, -1.0, 1.0, 0.0));
}

// d normalised, or the unit fallback where d has a non-finite component, is too short to
// have a direction (|d|^2 <= 1e-12) or too long to square (|d|^2 overflows); oct_decode
// returns none of these unless its texel is NaN or Inf. For the normal the lighting pass
// passes v as the fallback: a pixel whose normal is lost faces the viewer.
vec3 sanitize_direction(vec3 d, vec3 fallback) {
    bool finite = is_finite(d.x) && is_finite(d.y) && is_finite(d.z);
    float len2 = finite ? dot(d, d) : 0.0;
    return finite && is_finite(len2) && len2 > 1e-12 ? d * inversesqrt(len2) : fallback;
}

// The material row's numbers that extension textures scale per pixel, generated from
// app/common/extension_maps.py per factor target under its define:
// ModelParams scale_by_<target>(ModelParams p, vec4 f), each slot's factors clamped to
// [0, 1] (NaN: 1, no change) on the field of the map the row's selector picks (RT6: the
// sheen colour, or the specular colour where specular_color_map is 1, by RGB; the coat's
// strength, or the sheen roughness where sheen_roughness_map is 1, by A. RT8: the coat's
// roughness by R, the film's strength by G, its thickness mix(film_thickness_min,
// film_thickness, B)). The lighting pass applies them to the decoded row
// (gbuffer/decode.glsl), the forward pass to the fragment's.
#include "generated/extension_scaling.glsl"

// The metalness workflow (glTF 2.0 Appendix B; Burley 2012): one base colour serves
// as the diffuse albedo of a dielectric and as the F0 of a metal.
//   F0      = mix(f0_dielectric specular_color, base_color, metallic)
//   rho_ss  = (1 - metallic) base_color
// With SPECULAR_COLOR the dielectric's F0 is the G-buffer's one number times the
// material's specular_color (glTF KHR_materials_specular's coloured F0); without it the
// row's colour (white) is not read, and the F0 is what it always was.
vec3 material_F0(Surface s, ModelParams p) {
#if UBER_MODELS || SPECULAR_COLOR
    if (SPECULAR_COLOR != 0) {
        return mix(s.f0_dielectric * p.specular_color, s.base_color, s.metallic);
    }
#endif
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

// What f(l, v) needs of the point alone, the same for every light: brdf_view computes it
// once per point and each light's term (brdf_eval_view) reuses it, since llvmpipe's JIT
// moves nothing out of a loop (LLVM's LICM pass is not in its pipeline) and a light loop
// would otherwise recompute it per light (docs/performance.md, "Peers"). The same float32
// operations on the same values as inside the loop: the terms are bit for bit as before.
struct BrdfView {
    float NoV;            // n.v, clamped as shading_cosines clamps it
    float alpha;          // material_alpha
    vec3 F0;              // material_F0
    vec3 f_lambert;       // Fd_lambert of rho_ss
    float lambda_v_root;  // sqrt((n.v)^2 (1 - alpha^2) + alpha^2): V_height_correlated_GGX's
};

BrdfView brdf_view(ShadingPoint sp) {
    float NoV = clamp(dot(sp.n, sp.v), MIN_N_DOT_V, 1.0);
    float alpha = material_alpha(sp.s);
    return BrdfView(NoV, alpha, material_F0(sp.s, sp.params), Fd_lambert(material_rho_ss(sp.s)),
                    V_height_correlated_GGX_root(NoV, alpha * alpha));
}

// F(h, l) of the selected Fresnel model (RTR4 sec. 9.5). The exact models blend the
// dielectric interface and the metal by metallic, as the metalness workflow does.
// Like every dispatch function, a plain `if` on the constants of brdf/model.glsl: folded
// at compile time in a specialized pass, a run-time branch under UBER_MODELS.
vec3 F_base_selected(ShadingPoint sp, vec3 F0, float LoH) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    if (FRESNEL_MODEL == FRESNEL_SCHLICK_GENERALIZED) {
        return F_schlick_generalized(F0, p.f90, p.fresnel_exponent, LoH);
    }
    if (FRESNEL_MODEL == FRESNEL_DIELECTRIC) {
        return mix(vec3(F_dielectric(p.eta_dielectric, LoH)), F_schlick(s.base_color, LoH),
                   s.metallic);
    }
    if (FRESNEL_MODEL == FRESNEL_CONDUCTOR) {
        return mix(vec3(F_dielectric(p.eta_dielectric, LoH)), F_conductor(p.eta, p.k, LoH),
                   s.metallic);
    }
    if (FRESNEL_INTERNAL != 0) {
        // n1 > n2: Schlick at the transmitted angle, exactly 1 past the critical angle.
        return F_schlick(F0, cos_theta_schlick(p.eta_dielectric, LoH));
    }
    return F_schlick(F0, LoH);
}

#if UBER_MODELS || MULTISCATTER
// The hemispherical average F_avg = 2 int F mu dmu of the material's Fresnel (as
// F_base_selected computes F), for the multiple-scattering lobe (brdf/multiscatter.glsl):
// the exact models average the exact Fresnel of their dielectric part (eta_dielectric) and
// of their metal part (the conductor's eta + i k, or Schlick's of the base colour), mixed
// by metallic; the generalised Schlick F0 + (F90 - F0) 2 / ((e + 1)(e + 2)), e its exponent
// (2 int_0^1 (1 - mu)^e mu dmu = 2 B(2, e + 1)); Schlick's F0 + (1 - F0)/21 (e = 5) otherwise.
vec3 F_avg_selected(ShadingPoint sp) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    if (FRESNEL_MODEL == FRESNEL_CONDUCTOR) {
        return mix(vec3(F_avg_dielectric(p.eta_dielectric)), F_avg_conductor(p.eta, p.k),
                   s.metallic);
    }
    if (FRESNEL_MODEL == FRESNEL_DIELECTRIC) {
        return mix(vec3(F_avg_dielectric(p.eta_dielectric)),
                   s.base_color + (1.0 - s.base_color) / 21.0, s.metallic);
    }
    vec3 F0 = material_F0(s, p);
    if (FRESNEL_MODEL == FRESNEL_SCHLICK_GENERALIZED) {
        float e = p.fresnel_exponent;
        return F0 + (p.f90 - F0) * (2.0 / ((e + 1.0) * (e + 2.0)));
    }
    return F0 + (1.0 - F0) / 21.0;
}
#endif

// --- thin film (RTR4 sec. 9.11) ---
// The film over the material's base (brdf/thin_film.glsl): over the dielectric part the
// base index is eta_dielectric; over the metal part it is the conductor's eta + i k with
// FRESNEL_CONDUCTOR, and otherwise the metalness workflow's F0 (base_color) turned into a
// real index (ior_from_f0_rgb), as glTF KHR_materials_iridescence does. The two are mixed
// by metallic like the base's own F, and the result fades in over the base's F_base
// between 0 and FILM_FADE_NM: zero thickness is the base's Fresnel exactly (mix(a, b, 0)
// is a), whatever its model, and the film's exact interfaces take over without a jump.
// (Belcour and Barla's code fades the film's index to the medium's for the same reason.)
vec3 F_film_selected(ShadingPoint sp, float LoH, vec3 F_base) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    vec3 dielectric = F_thin_film(p.film_eta, p.film_ior, p.film_thickness,
                                  vec3(p.eta_dielectric), vec3(0.0), LoH);
    vec3 metal_eta = FRESNEL_MODEL == FRESNEL_CONDUCTOR ? p.eta : ior_from_f0_rgb(s.base_color);
    vec3 metal_k = FRESNEL_MODEL == FRESNEL_CONDUCTOR ? p.k : vec3(0.0);
    vec3 metal = F_thin_film(p.film_eta, p.film_ior, p.film_thickness, metal_eta, metal_k, LoH);
    vec3 film = mix(dielectric, metal, s.metallic);
    // film_factor: glTF iridescenceFactor, the film's strength (mix(F_base, F_film, f))
    return mix(F_base, film, smoothstep(0.0, FILM_FADE_NM, p.film_thickness) * p.film_factor);
}

// F(h, l) of the material: the base's Fresnel (F_base_selected), or a thin film's over it
// with THIN_FILM. Without a film this is F_base_selected alone, as it always was.
// F0: material_F0 of sp (a BrdfView's, computed once per point).
vec3 F_selected(ShadingPoint sp, vec3 F0, float LoH) {
    vec3 F = F_base_selected(sp, F0, LoH);
#if UBER_MODELS || THIN_FILM
    if (THIN_FILM != 0) F = F_film_selected(sp, LoH, F);
#endif
    return F;
}

// The diffuse (subsurface) lobe of the selected model (RTR4 sec. 9.9) towards sp.v.
// bv: sp's BrdfView (its alpha, F0 and Lambert lobe).
vec3 f_diffuse_selected(ShadingPoint sp, BrdfView bv, vec3 l, float NoL, float NoV, float NoH,
                        float LoH) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    vec3 n = sp.n;
    vec3 v = sp.v;
    float alpha = bv.alpha;
    vec3 rho_ss = material_rho_ss(s);
    float r = clamp(s.perceptual_roughness, 0.0, 1.0);
    if (DIFFUSE_MODEL == DIFFUSE_SHIRLEY) {
        return Fd_shirley(rho_ss, bv.F0, NoL, NoV);
    }
    if (DIFFUSE_MODEL == DIFFUSE_ASHIKHMIN_SHIRLEY) {
        return Fd_ashikhmin_shirley(rho_ss, bv.F0, NoL, NoV);
    }
    if (DIFFUSE_MODEL == DIFFUSE_BURLEY) return Fd_burley(rho_ss, r, NoL, NoV, LoH);
    if (DIFFUSE_MODEL == DIFFUSE_BURLEY_RENORMALIZED) {
        return Fd_burley_renormalized(rho_ss, r, NoL, NoV, LoH);
    }
    if (DIFFUSE_MODEL == DIFFUSE_OREN_NAYAR) return Fd_oren_nayar(rho_ss, alpha, n, l, v);
    if (DIFFUSE_MODEL == DIFFUSE_HAMMON) {
        return Fd_hammon(rho_ss, bv.F0, alpha, NoL, NoV, NoH, dot(l, v));
    }
    if (DIFFUSE_MODEL == DIFFUSE_NONE) return vec3(0.0);
    if (DIFFUSE_MODEL == DIFFUSE_CLOTH_EMPIRICAL) {  // RTR4 sec. 9.10 (brdf/cloth.glsl)
        return f_cloth_empirical(CLOTH_WRAP_FORM == CLOTH_WRAP_RTR4, rho_ss, p.cloth_rim_inner,
                                 p.cloth_diffuse, p.cloth_scatter, p.cloth_wrap, p.cloth_sheen,
                                 NoL, NoV, LoH);
    }
    return bv.f_lambert;
}

// A unit tangent perpendicular to n: t with its normal component removed, or any
// perpendicular where t is (numerically) parallel to n or zero.
vec3 orthonormal_tangent(vec3 n, vec3 t) {
    vec3 u = t - n * dot(n, t);
    float len2 = dot(u, u);
    if (len2 > 1e-8) return u * inversesqrt(len2);
    vec3 a = abs(n.z) < 0.999 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    return normalize(cross(a, n));
}

// The clamped cosines every BRDF evaluation starts from (twin: material.py
// shading_cosines): n.l floored at MIN_N_DOT_L so no 1/(n.l) underflows, n.v at MIN_N_DOT_V
// (interpolated normals can face away from the eye), and the half vector, n where l = -v
// (possible only when the true n.v < 0) has none.
void shading_cosines(vec3 n, vec3 l, vec3 v, out float NoL, out float NoV, out vec3 h) {
    NoL = clamp(dot(n, l), MIN_N_DOT_L, 1.0);
    NoV = clamp(dot(n, v), MIN_N_DOT_V, 1.0);
    vec3 hv = l + v;
    float hv2 = dot(hv, hv);
    h = hv2 > 1e-12 ? hv * inversesqrt(hv2) : n;
}

#if UBER_MODELS || DIFFRACTION_MODEL != DIFFRACTION_NONE
// --- diffraction grating (RTR4 sec. 9.11, brdf/diffraction.glsl) ---
// The single-scattering lobe F D V at any pair (l, v) of upper-hemisphere directions, not
// only at sp.v: the orders shift v as well as l (shading_cosines; the fused
// height-correlated GGX visibility, the only G2 a grating takes).
vec3 grating_lobe(ShadingPoint sp, float alpha, vec3 l, vec3 v) {
    vec3 n = sp.n;
    float NoL, NoV;
    vec3 h;
    shading_cosines(n, l, v, NoL, NoV, h);
    float LoH = clamp(dot(l, h), 0.0, 1.0);
    vec3 F = F_selected(sp, material_F0(sp.s, sp.params), LoH);
    float D = D_selected(n, h, alpha, sp.params.gtr_gamma);
    return F * (D * V_height_correlated_GGX(NoL, NoV, alpha));
}

// The grating's orders over the lobe, grooves along the tangent t (g = n x t):
//   sum_lambda W(lambda) sum_|m|<=ORDERS eta_m (f(l, v'_m) + f(l'_m, v)) / 2 (m = 0: f),
// clamped at 0 (a narrow band lies outside the sRGB gamut). f0 is f(l, v), v = sp.v.
vec3 f_spec_grating_selected(ShadingPoint sp, vec3 l, float NoL, float NoV, float alpha,
                             vec3 f0) {
    ModelParams p = sp.params;
    vec3 n = sp.n;
    vec3 v = sp.v;
    vec3 g = cross(n, orthonormal_tangent(n, sp.t));
    vec3 total = vec3(0.0);
    for (int j = 0; j < GRATING_SAMPLES; ++j) {
        float lambda_nm = grating_wavelength(j);
        vec3 band = grating_efficiency(0, p.grating_depth, lambda_nm, NoL, NoV) * f0;
        for (int m = -GRATING_ORDERS; m <= GRATING_ORDERS; ++m) {
            if (m == 0) continue;
            float shift = float(m) * lambda_nm / p.grating_period;
            bool v_ok, l_ok;
            vec3 vm = grating_shifted(v, n, g, shift, v_ok);
            vec3 lm = grating_shifted(l, n, g, shift, l_ok);
            vec3 half_sum = v_ok ? grating_lobe(sp, alpha, l, vm) : vec3(0.0);
            if (l_ok) half_sum += grating_lobe(sp, alpha, lm, v);
            float eta = grating_efficiency(m, p.grating_depth, lambda_nm, NoL, NoV);
            band += (0.5 * eta) * half_sum;
        }
        total += GRATING_WEIGHTS[j] * band;
    }
    return max(total, vec3(0.0));
}
#endif

// RTR4 sec. 9.1: the surface (specular: f_spec and f_ms) and subsurface (diffuse)
// reflections as separate contributions. BRDF_TERMS selects which brdf_eval returns,
// a compile-time bitmask of TERM_SPECULAR and TERM_DIFFUSE (render.terms; the bits are
// generated from app/common/models.py): both by default.
#ifndef BRDF_TERMS
#define BRDF_TERMS 3
#endif

// The factors of f(l, v) at one lit point, apart: brdf_eval adds them up, and the debug
// views (glsl/passes/debug.frag, app/render/debug_views.py) show each one alone.
struct BrdfFactors {
    vec3 F;           // Fresnel reflectance F(h, l) (RTR4 sec. 9.5)
    float D;          // NDF D(h) (RTR4 sec. 9.7, 9.8)
    float G2;         // joint masking-shadowing G2(l, v, h) (RTR4 sec. 9.7)
    float f_coat;     // a clear coat's own reflection c f_coat (RTR4 sec. 9.12); 0 without
    vec3 f_spec;      // F G2 D / (4 n.l n.v), plus f_ms with MULTISCATTER (RTR4 sec. 9.8)
    vec3 f_diffuse;   // the subsurface lobe (RTR4 sec. 9.9)
};

// The surface reflection of the factors: the coat's lobe plus the base's specular lobe (the
// sum every consumer of f_spec sees; f_coat + f_spec, in this order, as before the two
// were kept apart).
vec3 surface_reflection(BrdfFactors b) {
#if CLEARCOAT_ON
    return vec3(b.f_coat) + b.f_spec;
#else
    return b.f_spec;
#endif
}

// The factors for unit l and the point's n, v with n.l > 0 (brdf_eval returns 0 before it
// calls this) and tangent t (used only by anisotropic NDFs). n.v is clamped to MIN_N_DOT_V as
// interpolated normals can face away from the eye, and n.l to MIN_N_DOT_L (1e-20) so that
// no 1/(n.l) underflows (see constants.glsl). Where the model has a fused visibility term
// V = G2/(4 n.l n.v), f_spec is computed from V as it always was and G2 is V 4 n.l n.v, a
// value only the debug views read (the compiler drops it from brdf_eval).
// The base's factors: the whole BRDF without a clear coat (brdf_factors adds the coat).
// bv: brdf_view(sp), the factors of the point alone (the view's n.v and root are used
// where they equal shading_cosines' and V_height_correlated_GGX's own).
BrdfFactors base_brdf_factors_view(ShadingPoint sp, BrdfView bv, vec3 l) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    vec3 n = sp.n;
    vec3 t = sp.t;
    vec3 v = sp.v;
    float NoL, NoV_unused;
    vec3 h;
    shading_cosines(n, l, v, NoL, NoV_unused, h);
    float NoV = bv.NoV;
    float NoH = clamp(dot(n, h), 0.0, 1.0);
    float LoH = clamp(dot(l, h), 0.0, 1.0);
    float alpha = bv.alpha;
    vec3 F = F_selected(sp, bv.F0, LoH);

    float D;
    float alpha_v = alpha;
    float alpha_l = alpha;
    if (ANISOTROPIC != 0) {
        vec3 tn = orthonormal_tangent(n, t);
        vec3 bn = cross(n, tn);
        float alpha_min = MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS;
        float alpha_x = max(alpha * (1.0 + s.anisotropy), alpha_min);
        float alpha_y = max(alpha * (1.0 - s.anisotropy), alpha_min);
        D = D_selected_aniso(n, tn, bn, h, alpha_x, alpha_y);
        alpha_v = alpha_in_direction(tn, bn, v, alpha_x, alpha_y);
        alpha_l = alpha_in_direction(tn, bn, l, alpha_x, alpha_y);
    } else {
        D = D_selected(n, h, alpha, p.gtr_gamma);
    }

    float G2;
    vec3 f_spec;
    if (G2_MODEL == G2_HAMMON) {
        float V = V_hammon_GGX(NoL, NoV, alpha);
        f_spec = F * (D * V);
        G2 = V * (4.0 * NoL * NoV);
    } else if (!SPECULAR_LAMBDA_G2) {
        // The division-free visibility form: accurate as n.l or n.v -> 0.
        float V = V_height_correlated_GGX_view(NoL, NoV, alpha, bv.lambda_v_root);
        f_spec = F * (D * V);
        G2 = V * (4.0 * NoL * NoV);
    } else {
        G2 = G2_selected(Lambda_selected(NoV, alpha_v, p.gtr_gamma),
                         Lambda_selected(NoL, alpha_l, p.gtr_gamma), n, l, v);
        f_spec = F * (D * G2 / (4.0 * NoL * NoV));
    }
#if UBER_MODELS || DIFFRACTION_MODEL != DIFFRACTION_NONE
    // diffraction grating (RTR4 sec. 9.11): the orders replace the lobe
    if (DIFFRACTION_MODEL == DIFFRACTION_GRATING) {
        f_spec = f_spec_grating_selected(sp, l, NoL, NoV, alpha, f_spec);
    }
#endif
#if UBER_MODELS || MULTISCATTER
    // brdf/multiscatter.glsl declares the table and its functions only under this condition.
    if (MULTISCATTER != 0) {
        f_spec += f_ms_kulla_conty_F_avg(F_avg_selected(sp), s.perceptual_roughness, NoL, NoV);
    }
#endif
    vec3 f_diffuse = f_diffuse_selected(sp, bv, l, NoL, NoV, NoH, LoH);
#if UBER_MODELS || FIBER_MODEL != FIBER_NONE
    // micro-cylinder fibres (RTR4 sec. 9.10, brdf/fiber.glsl): the thread along the tangent
    // turned by fiber_rotation replaces both lobes (its surface reflection in f_spec, its
    // diffuse or volume scattering in f_diffuse); its longitudinal width gamma_s is alpha,
    // its index the dielectric's. The scene format allows no other layer over it.
    if (FIBER_MODEL != FIBER_NONE) {
        vec3 tf = fiber_rotate(n, orthonormal_tangent(n, t), p.fiber_rotation);
        f_fiber(FIBER_MODEL == FIBER_SADEGHI, n, tf, l, v, NoL, material_rho_ss(s),
                material_F0(s, p), p.eta_dielectric, alpha, p.fiber_curvature, p.fiber_gamma_v,
                p.fiber_kd, f_spec, f_diffuse);
    }
#endif
#if UBER_MODELS || SHEEN_MODEL != SHEEN_NONE
    // sheen (RTR4 sec. 9.10, brdf/sheen.glsl): the cloth layer over the whole base,
    // f = f_sheen + f_base (1 - max(sheen_color) max(E(n.l), E(n.v))). The sheen is a
    // surface reflection, so it joins f_spec (TERM_SPECULAR; the debug views' f_spec).
    if (SHEEN_MODEL != SHEEN_NONE) {
        float scale = sheen_scaling(p.sheen_color, p.sheen_roughness, NoL, NoV);
        f_spec = f_spec * scale
               + f_sheen_selected(p.sheen_color, p.sheen_roughness, n, h, NoL, NoV);
        f_diffuse *= scale;
    }
#endif
    return BrdfFactors(F, D, G2, 0.0, f_spec, f_diffuse);
}

BrdfFactors base_brdf_factors(ShadingPoint sp, vec3 l) {
    return base_brdf_factors_view(sp, brdf_view(sp), l);
}

#if CLEARCOAT_ON
// --- clear coat (RTR4 sec. 9.12) ---
// The base under a coat: its interface is with the coat (index eta), so its Fresnel is
// relative to the coat, mixed in by the strength c (exact at c = 0 and 1): the dielectric
// F0 by f0_under_clearcoat, the exact models' indices divided by eta. A metal's F0 (its
// base colour) is kept: for a metal's complex index the change is small (gold's F0 0.92 in
// air, 0.90 under eta = 1.5: docs/layered.md).
Surface clearcoat_base_surface(Surface s, ModelParams p) {
    s.f0_dielectric = mix(s.f0_dielectric, f0_under_clearcoat(s.f0_dielectric, p.clearcoat_eta),
                          p.clearcoat);
    return s;
}

ModelParams clearcoat_base_params(ModelParams p) {
    float c = p.clearcoat;
    p.eta_dielectric = mix(p.eta_dielectric, p.eta_dielectric / p.clearcoat_eta, c);
    p.eta = mix(p.eta, p.eta / p.clearcoat_eta, c);
    p.k = mix(p.k, p.k / p.clearcoat_eta, c);
    return p;
}

// The base as the coat's underside sees it: its surface and parameters under the coat
// and the view v_base (refracted into the coat for Weidlich-Wilkie, else sp.v).
ShadingPoint clearcoat_base_point(ShadingPoint sp, vec3 v_base) {
    ShadingPoint base = sp;
    base.s = clearcoat_base_surface(sp.s, sp.params);
    base.params = clearcoat_base_params(sp.params);
    base.v = v_base;
    return base;
}

// K of the coat-base inter-reflection series (CLEARCOAT_WEIDLICH_WILKIE_SERIES; twin
// clearcoat_series): the light the coat's top reflects back down, summed over its bounces,
// leaves as the broad lobe w K / pi (w: the single pass's crossings, absorption and
// 1/eta_c^2), in f_diffuse. R = R_d + R_s the base's average albedo under the coat (R_d its
// rho_ss, R_s Schlick's F_avg of its F0 times E_avg(r); scaled down together where they
// sum past 1), Q = R_d r_i + R_s r_s the share trapped on the first return, A_rt = T0^4 a
// round trip's absorption (diffuse light's mean path is 2/cos per leg):
//   K = Q A_rt R / (1 - R r_i A_rt), the geometric sum of the bounces after the first.
vec3 clearcoat_series(ShadingPoint sp, float c) {
    ModelParams p = sp.params;
    Surface base = clearcoat_base_surface(sp.s, p);
    float eta_c = mix(1.0, p.clearcoat_eta, c);
    float F0c = clearcoat_F0(p.clearcoat_eta);
    float r_i = clearcoat_internal_reflectance(c, F0c, eta_c);
    float r_s = clearcoat_lobe_trapping(c, F0c, eta_c, r_i, material_alpha(base));
    vec3 F0 = material_F0(base, clearcoat_base_params(p));
    vec3 R_s = (F0 + (1.0 - F0) / 21.0) * E_avg_ggx_fit(base.perceptual_roughness);
    vec3 R_d = material_rho_ss(base);
    vec3 scale = 1.0 / max(R_d + R_s, vec3(1.0));
    R_d *= scale;
    R_s *= scale;
    vec3 R = R_d + R_s;
    vec3 Q = R_d * r_i + R_s * r_s;
    vec3 T0 = p.clearcoat_color;
    vec3 A_rt = mix(vec3(1.0), (T0 * T0) * (T0 * T0), c);
    return Q * A_rt * R / (1.0 - R * r_i * A_rt);
}

// The coated BRDF's factors; F, D and G2 stay the base's (what the debug views show), the
// coat's reflection is f_coat (surface reflection, RTR4 sec. 9.1: it joins f_spec in
// surface_reflection) and the base's two lobes are weighted by what reaches them through the
// coat and back.
// CLEARCOAT_FILAMENT (Filament; glTF KHR_materials_clearcoat), with strength c:
//   f = c f_coat(l, v) + (1 - c F(nc.l)) (1 - c F(nc.v)) mix(1, A(l, v), c) f_base(l, v).
// CLEARCOAT_WEIDLICH_WILKIE (Weidlich & Wilkie 2007, "Arbitrarily Layered Micro-Facet
// Surfaces", two layers, a flat coat): the base sees the directions refracted into the coat,
//   f = c f_coat(l, v) + (1 - c F(nc.l)) (1 - c F(nc.v)) mix(1, A, c) f_base(l_t, v_t) / eta_c^2,
// l_t, v_t by Snell's law at eta_c = mix(1, eta, c) (the medium's index at c = 0: the base
// unchanged), 1/eta_c^2 the solid-angle compression of the refraction (clearcoat.glsl).
// CLEARCOAT_WEIDLICH_WILKIE_SERIES: the same plus the light the coat reflects back down
// to the base, summed over its bounces (clearcoat_series). Left out, as in the paper: refraction through the coat's microfacets (the macro normal
// refracts), and the paper's empirical compensation term t.
// Two normals (RTR4 sec. 9.12: "layers may have different normals"): the coat's nc and the
// base's n. The coat's lobe, its Fresnel crossings 1 - c F and the Beer-Lambert path lengths
// take nc (the coat's interface is where light crosses); the base's lobes take n. For
// Weidlich-Wilkie the coat's interface refracts, so l and v refract about nc and the base
// evaluates the refracted directions about its own n. With nc = n every number is the one
// a single normal gives, bit for bit (the same operations on the same values).
BrdfFactors clearcoat_factors(ShadingPoint sp, vec3 l) {
    ModelParams p = sp.params;
    vec3 nc = sp.nc;
    vec3 v = sp.v;
    float NoL, NoV;
    vec3 h;
    shading_cosines(nc, l, v, NoL, NoV, h);   // the coat's cosines
    float LoH = clamp(dot(l, h), 0.0, 1.0);
    float c = p.clearcoat;
    float F0c = clearcoat_F0(p.clearcoat_eta);
    float rc = max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    float alpha_c = rc * rc;

    vec3 l_base = l;
    vec3 v_base = v;
    float compression = 1.0;
    bool refracts = CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE
                 || CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE_SERIES;
    if (refracts && c > 0.0) {
        float eta_c = mix(1.0, p.clearcoat_eta, c);
        l_base = clearcoat_refract_in(eta_c, nc, l);
        v_base = clearcoat_refract_in(eta_c, nc, v);
        compression = clearcoat_solid_angle_compression(eta_c);
    }
    BrdfFactors b = base_brdf_factors(clearcoat_base_point(sp, v_base), l_base);
    float T = T_clearcoat_filament(c, F0c, NoL, NoV);
    vec3 A = mix(vec3(1.0), A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL,
                                                     NoV), c);
    vec3 w = (T * compression) * A;
    // chi+(nc.l): a light below the coat's horizon has no coat lobe (brdf_eval has already
    // returned 0 for one below n's, so at nc = n this selects nothing).
    b.f_coat = dot(nc, l) > 0.0 ? c * f_clearcoat_ggx(alpha_c, F0c, nc, h, NoL, NoV, LoH) : 0.0;
    b.f_spec = w * b.f_spec;
    b.f_diffuse = w * b.f_diffuse;
    if (CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE_SERIES) {
        b.f_diffuse += w * clearcoat_series(sp, c) * (1.0 / PI);
    }
    return b;
}
#endif

// The factors of the material's BRDF: the base's, or, with a clear coat, the coated ones
// with the coat's normal nc (n where the coat has no normal of its own: docs/layered.md).
// bv: brdf_view(sp) (a coat computes its base's own: the base sees another point).
BrdfFactors brdf_factors_view(ShadingPoint sp, BrdfView bv, vec3 l) {
#if CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE) return clearcoat_factors(sp, l);
#endif
    return base_brdf_factors_view(sp, bv, l);
}

BrdfFactors brdf_factors(ShadingPoint sp, vec3 l) {
    return brdf_factors_view(sp, brdf_view(sp), l);
}

// The reflections BRDF_TERMS keeps of the base's lobes (the coat's is surface reflection).
vec3 selected_terms(vec3 f_diffuse, vec3 f_surface) {
#if BRDF_TERMS == (TERM_SPECULAR | TERM_DIFFUSE)
    return f_diffuse + f_surface;
#elif BRDF_TERMS == TERM_SPECULAR
    return f_surface;
#else
    return f_diffuse;
#endif
}

// f(l, v) = f_diffuse + f_spec (+ f_ms): the BRDF, without the cosine, for unit l and the
// point's unit n, v, the coat's normal nc (unused without a coat) and the tangent t; zero
// for lights below the surface (brdf_factors for the clamps). bv: brdf_view(sp), computed
// once for all the point's lights (a light loop's caller); brdf_eval computes it itself.
vec3 brdf_eval_view(ShadingPoint sp, BrdfView bv, vec3 l) {
    if (dot(sp.n, l) <= 0.0) return vec3(0.0);
    BrdfFactors b = brdf_factors_view(sp, bv, l);
    return selected_terms(b.f_diffuse, surface_reflection(b));
}

vec3 brdf_eval(ShadingPoint sp, vec3 l) {
    return brdf_eval_view(sp, brdf_view(sp), l);
}

#if UBER_MODELS || DIFFUSE_MODEL == DIFFUSE_CLOTH_EMPIRICAL
// Wrap lighting past the terminator (RTR4 sec. 9.10): f (n.l) of a light at n.l <=
// CLOTH_WRAP_MIN_N_DOT_L on an empirical cloth with wrap w > 0 (the illumination sum asks
// only there), the wrapped lobes alone (brdf/cloth.glsl). A diffuse reflection: zero where
// BRDF_TERMS leaves the diffuse out. The scene format refuses a wrap under a clear coat or a
// sheen layer (app/common/material_checks.py), whose weights this does not apply.
vec3 cloth_wrapped_term(ShadingPoint sp, float NoL) {
    if ((BRDF_TERMS & TERM_DIFFUSE) == 0) return vec3(0.0);
    ModelParams p = sp.params;
    float NoV = clamp(dot(sp.n, sp.v), MIN_N_DOT_V, 1.0);
    return f_cloth_empirical_past_terminator(CLOTH_WRAP_FORM == CLOTH_WRAP_RTR4,
                                             material_rho_ss(sp.s), p.cloth_rim_inner,
                                             p.cloth_diffuse, p.cloth_scatter, p.cloth_wrap,
                                             NoL, NoV);
}
#endif

#if CLEARCOAT_ON
// f(l, v) times the cosine, for a coat whose normal nc is not the base's n: each layer's
// lobe takes its own cosine, the coat's (nc.l)+ and the base's (seen through the coat)
// (n.l)+, as Filament's surface shading does with a clear-coat normal; with one cosine the
// base's bumps would show in a smooth coat's highlight. glTF KHR_materials_clearcoat: the
// coat's normal "affects the top layer, but not the base". Zero where the light is below
// both. Each term is selected, not multiplied by 0: a lobe at a direction below its
// layer's horizon is evaluated with clamped cosines and never reaches the sum.
vec3 brdf_eval_layered_cos(ShadingPoint sp, vec3 l) {
    float NoL = dot(sp.n, l);
    float NoLc = dot(sp.nc, l);
    if (NoL <= 0.0 && NoLc <= 0.0) return vec3(0.0);
    BrdfFactors b = brdf_factors(sp, l);
    vec3 base = selected_terms(b.f_diffuse, b.f_spec);
    float coat = (BRDF_TERMS & TERM_SPECULAR) != 0 ? b.f_coat : 0.0;
    vec3 result = NoL > 0.0 ? base * NoL : vec3(0.0);
    return NoLc > 0.0 ? result + vec3(coat * NoLc) : result;
}
#endif

#endif
