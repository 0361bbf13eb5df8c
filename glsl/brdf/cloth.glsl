// The empirical cloth terms of RTR4 sec. 9.10 (diffuse = "cloth_empirical").
// Twin: app/reference/cloth.py. docs/cloth.md, section "Empirical", has the proofs and
// the measured numbers.
// The caller guarantees n.l > 0, clamps n.l to [MIN_N_DOT_L, 1] and n.v to
// [MIN_N_DOT_V, 1], and passes l.h clamped to [0, 1].
#ifndef PBS_CLOTH_GLSL
#define PBS_CLOTH_GLSL

#include "common/constants.glsl"
#include "brdf/fresnel.glsl"

// Below this n.l the wrap factor divides by it instead of n.l (see wrap_cloth_empirical).
const float CLOTH_WRAP_MIN_N_DOT_L = 1e-4;

// Hable 2010, "Uncharted 2: Character Lighting and Shading" (SIGGRAPH course), as RTR4
// sec. 9.10 gives it: rim, inner and diffuse lobes, all functions of the view alone:
//   f = rho_ss/pi (k_rim (n.v)^a_rim + k_inner (1 - n.v)^a_inner + k_diff).
// Not reciprocal: the rim and inner lobes depend on v only (k_rim = k_inner = 0 leaves
// Lambert times k_diff, which is). Precision: pow(x, a) is exp2(a log2 x) in float32;
// a_rim, a_inner > 0 (the scene format), so pow(0, a) = 0 at n.v = 1 is defined.
vec3 Fd_cloth_empirical(vec3 rho_ss, vec4 rim_inner, float k_diff, float NoV) {
    float rim = rim_inner.x * pow(NoV, rim_inner.y);
    float inner = rim_inner.z * pow(1.0 - NoV, rim_inner.w);
    return rho_ss * (INV_PI * (rim + inner + k_diff));
}

// Energy-conserving wrap lighting with a scatter colour, the form RTR4 sec. 9.10 gives
// (Filament's cloth model uses the same; its original game source is RTR4's, not checked):
//   f_diff (n.l)+  =>  f_diff clamp(c_scatter + n.l, 0, 1) (n.l + w)+ / (1 + w)^2.
// The (1 + w)^2 makes it conserve energy: over the whole sphere of l,
//   int (n.l + w)+ / (1 + w)^2 dl = 2 pi / (1 + w)^2 int_{-w}^{1} (mu + w) dmu = pi
//                                 = int (n.l)+ dl,
// and clamp(c + n.l, 0, 1) <= 1 only removes light. The illumination sum multiplies f by
// (n.l)+ outside the BRDF, so this returns the factor divided by n.l,
//   W = clamp(c_scatter + n.l, 0, 1) (1 + w / n.l) / (1 + w)^2,
// and the light behind the surface (-w < n.l <= 0) that wrap lighting would add is NOT
// added (light_contribution returns 0 there): a white furnace loses w^2/(1 + w)^2 of it.
// Precision: 1 + w/n.l, not (n.l + w)/n.l: w = 0 and c_scatter = 1 give W = 1 exactly.
// Guard: n.l is floored at CLOTH_WRAP_MIN_N_DOT_L in the division (the caller's floor 1e-20
// made W 5e19 and, times a near light's c_light, overflowed); below it the sum's f (n.l) is
// (n.l + w) n.l / 1e-4 instead of n.l + w, a loss of at most w 1e-4 / (1 + w)^2 of the
// furnace's irradiance.
vec3 wrap_cloth_empirical(vec3 c_scatter, float w, float NoL) {
    float k = (1.0 + w / max(NoL, CLOTH_WRAP_MIN_N_DOT_L)) / ((1.0 + w) * (1.0 + w));
    return clamp(c_scatter + NoL, 0.0, 1.0) * k;
}

// The Schlick-like sheen of RTR4 sec. 9.10 (a Fresnel-like grazing term of the empirical
// game models; its original source is RTR4's, not checked here):
//   f_sheen = k_sheen c_sheen (1 - (h.l)+)^5,
// sheen = k_sheen c_sheen premultiplied. Reciprocal: h.l = h.v.
vec3 f_sheen_cloth_empirical(vec3 sheen, float LoH) {
    return sheen * pow5_one_minus(LoH);
}

// The whole empirical cloth diffuse model: the lobes through the wrap, plus the sheen.
vec3 f_cloth_empirical(vec3 rho_ss, vec4 rim_inner, float k_diff, vec3 c_scatter, float w,
                       vec3 sheen, float NoL, float NoV, float LoH) {
    vec3 lobes = Fd_cloth_empirical(rho_ss, rim_inner, k_diff, NoV);
    return lobes * wrap_cloth_empirical(c_scatter, w, NoL) + f_sheen_cloth_empirical(sheen, LoH);
}

#endif
