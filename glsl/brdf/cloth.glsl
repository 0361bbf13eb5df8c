// The empirical cloth terms of RTR4 sec. 9.10 (diffuse = "cloth_empirical").
// Twin: app/reference/cloth.py. docs/cloth.md, section "Empirical", has the proofs and
// the measured numbers.
// The caller of f_cloth_empirical guarantees n.l > 0, clamps n.l to [MIN_N_DOT_L, 1] and
// n.v to [MIN_N_DOT_V, 1], and passes l.h clamped to [0, 1]; the illumination sum calls
// f_cloth_empirical_past_terminator for the wrapped light at n.l <= CLOTH_WRAP_MIN_N_DOT_L.
#ifndef PBS_CLOTH_GLSL
#define PBS_CLOTH_GLSL

#include "common/constants.glsl"
#include "brdf/fresnel.glsl"

// At and below this n.l the wrapped light is f_cloth_empirical_past_terminator's (not divided
// by n.l); above it wrap_cloth_empirical divides by n.l.
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

// Wrap lighting with a scatter colour (RTR4 sec. 9.10): light reaches past the terminator,
//   f_diff (n.l)+  =>  f_diff clamp(c_scatter + (n.l)+, 0, 1) cos_w(n.l),
// cos_w the wrapped cosine (wrapped_cosine_cloth_empirical), in one of two forms:
//   the book's (RTR4 sec. 9.10, the curriculum's)  cos_w = clamp(n.l + w, 0, 1) / (1 + w);
//   Filament's (its Fd_Wrap)                        cos_w = (n.l + w)+ / (1 + w)^2.
// Over the whole sphere of l, int (n.l + w)+ / (1 + w)^2 dl = 2 pi / (1 + w)^2
// int_{-w}^{1} (mu + w) dmu = pi = int (n.l)+ dl: Filament's form conserves energy (its head-on
// light is 1/(1 + w) of Lambert's). The book's keeps a head-on light at Lambert's and gives
// pi (1 + 2w)/(1 + w): a white furnace reflects (1 + 2w)/(1 + w) (w = 0.5: 4/3).
// rtr4: the book's form, else Filament's. Any n.l in [-1, 1].
float wrapped_cosine_cloth_empirical(bool rtr4, float w, float NoL) {
    return rtr4 ? clamp(NoL + w, 0.0, 1.0) / (1.0 + w)
                : max(NoL + w, 0.0) / ((1.0 + w) * (1.0 + w));
}

// The wrap on the lit side (n.l > CLOTH_WRAP_MIN_N_DOT_L), divided by n.l: the illumination
// sum multiplies f by n.l outside the BRDF, so the BRDF carries
//   W = clamp(c_scatter + n.l, 0, 1) cos_w(n.l) / n.l
// (Filament's: (1 + w / n.l) / (1 + w)^2; the book's: min(1 + w / n.l, 1 / n.l) / (1 + w)).
// Precision: 1 + w/n.l, not (n.l + w)/n.l: w = 0 and c_scatter = 1 give W = 1 exactly.
// Guard: n.l is floored at CLOTH_WRAP_MIN_N_DOT_L in the division (the caller's floor 1e-20
// made W 5e19 and, times a near light's c_light, overflowed); below it the illumination sum
// takes f_cloth_empirical_past_terminator instead, which is not divided.
vec3 wrap_cloth_empirical(bool rtr4, vec3 c_scatter, float w, float NoL) {
    float d = max(NoL, CLOTH_WRAP_MIN_N_DOT_L);
    float k = rtr4 ? min(1.0 + w / d, 1.0 / d) / (1.0 + w)
                   : (1.0 + w / d) / ((1.0 + w) * (1.0 + w));
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
vec3 f_cloth_empirical(bool rtr4, vec3 rho_ss, vec4 rim_inner, float k_diff, vec3 c_scatter,
                       float w, vec3 sheen, float NoL, float NoV, float LoH) {
    vec3 lobes = Fd_cloth_empirical(rho_ss, rim_inner, k_diff, NoV);
    return lobes * wrap_cloth_empirical(rtr4, c_scatter, w, NoL)
         + f_sheen_cloth_empirical(sheen, LoH);
}

// Past the terminator (n.l <= CLOTH_WRAP_MIN_N_DOT_L, down to -w), the wrapped lobes times
// the wrapped cosine, f (n.l) itself and not divided by n.l:
//   lobes(v) clamp(c_scatter + (n.l)+, 0, 1) cos_w(n.l).
// The sheen is a reflection of the lit side and adds nothing here. At n.l = 0 this equals the
// lit side's f (n.l) without the sheen (lobes c_scatter w / (1 + w)^2 in Filament's form), so
// the terminator is a gradient down to n.l = -w, not a step.
vec3 f_cloth_empirical_past_terminator(bool rtr4, vec3 rho_ss, vec4 rim_inner, float k_diff,
                                       vec3 c_scatter, float w, float NoL, float NoV) {
    vec3 lobes = Fd_cloth_empirical(rho_ss, rim_inner, k_diff, NoV);
    vec3 tint = clamp(c_scatter + max(NoL, 0.0), 0.0, 1.0);
    return lobes * (tint * wrapped_cosine_cloth_empirical(rtr4, w, NoL));
}

#endif
