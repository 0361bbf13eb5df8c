// Multiple-scattering compensation of the GGX specular. Twin: app/reference/multiscatter.py.
// Kulla & Conty 2017, "Revisiting Physically Based Shading at Imageworks" (SIGGRAPH course).
// Everything is inside #if MULTISCATTER (or UBER_MODELS, the uber-shader that compiles every
// model; brdf/model.glsl), so a program built without it pays nothing.
//
// u_ms_table (app/render/tables.py, ms_texture): RG32F, NEAREST, width n_mu, height
// MS_FORMS n_r: one n_r-row block per G2 form (app/common/tables.py MS_FORMS), each E of
// the GGX specular with that G2, so the compensation is what the material's own G2 loses;
// in block b, texel (j, b n_r + i) = (1 - E(mu_j, r_i), 1 - E_avg(r_i)), the energy LOST by
// single scattering,
// on mu_j = (j/(n_mu - 1))^4 and r_i = 0.045 + 0.955 (i/(n_r - 1))^2: nodes crowded toward
// grazing and smooth, where E changes fastest. Storing the loss keeps its 7 digits in
// float32 where 1 - E would keep 1-3 for a smooth surface.
// Interpolation is bilinear in the grid coordinates (sqrt(sqrt(mu)) and
// sqrt((r - 0.045)/0.955): sqrt only, no pow), by hand with texelFetch, the same sums as
// the float64 twin: GPU filtering weighs texels with fixed-point fractions (8 bits on
// NVIDIA), up to 2e-3 of a cell's difference, and differs between drivers.
#ifndef PBS_MULTISCATTER_GLSL
#define PBS_MULTISCATTER_GLSL

#include "common/constants.glsl"
#include "brdf/model.glsl"
#include "brdf/fresnel.glsl"

#if UBER_MODELS || MULTISCATTER

uniform sampler2D u_ms_table;

// Below every real 1 - E_avg of the table (2.7e-5 at the roughness floor): only keeps a
// row that loses nothing (so 1 - E = 0 there too) from dividing 0 by 0.
const float MS_MIN_LOSS_AVG = 1e-6;

// The block of u_ms_table holding the material's G2 (MS_FORM_* generated from
// app/common/tables.py; a form that depends on lambda(phi) has one block per correlation,
// in CORRELATION order). A constant in a specialized pass, per pixel under UBER_MODELS.
int ms_form() {
    if (G2_MODEL == G2_DIRECTION_CORRELATED) return MS_FORM_DIRECTION_CORRELATED + CORRELATION;
    if (G2_MODEL == G2_HEIGHT_DIRECTION_CORRELATED) return MS_FORM_HEIGHT_DIRECTION_CORRELATED + CORRELATION;
    if (G2_MODEL == G2_SEPARABLE) return MS_FORM_SEPARABLE;
    if (G2_MODEL == G2_HAMMON) return MS_FORM_HAMMON;
    return MS_FORM_HEIGHT_CORRELATED;
}

// The table's size of one block: (n_mu, n_r).
ivec2 ms_size() {
    ivec2 size = textureSize(u_ms_table, 0);
    return ivec2(size.x, size.y / MS_FORMS);
}

// Grid coordinate s in [0, n - 1] -> cell index in [0, n - 2] and the fraction within it.
int ms_cell(float s, int n, out float t) {
    int i = min(int(s), n - 2);
    t = s - float(i);
    return i;
}

// Column coordinate of mu = n.l or n.v.
float ms_mu_coord(float mu, int n_mu) {
    return sqrt(sqrt(clamp(mu, 0.0, 1.0))) * float(n_mu - 1);
}

// Row coordinate of a perceptual roughness; roughness below the floor is the floor.
float ms_r_coord(float perceptual_roughness, int n_r) {
    float r = clamp(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    float u = (r - MIN_PERCEPTUAL_ROUGHNESS) / (1.0 - MIN_PERCEPTUAL_ROUGHNESS);
    return sqrt(u) * float(n_r - 1);
}

// 1 - E(mu, r). (1 - t) a + t b rather than a + t (b - a): all terms are >= 0, so the
// result keeps its relative precision where neighbouring losses differ tenfold.
float ms_loss(float mu, float perceptual_roughness) {
    ivec2 size = ms_size();
    float tx, ty;
    int j = ms_cell(ms_mu_coord(mu, size.x), size.x, tx);
    int i = ms_cell(ms_r_coord(perceptual_roughness, size.y), size.y, ty) + ms_form() * size.y;
    float a = texelFetch(u_ms_table, ivec2(j, i), 0).r;
    float b = texelFetch(u_ms_table, ivec2(j + 1, i), 0).r;
    float c = texelFetch(u_ms_table, ivec2(j, i + 1), 0).r;
    float d = texelFetch(u_ms_table, ivec2(j + 1, i + 1), 0).r;
    float lo = (1.0 - tx) * a + tx * b;
    float hi = (1.0 - tx) * c + tx * d;
    return (1.0 - ty) * lo + ty * hi;
}

// 1 - E_avg(r), linear in r (every column holds it; column 0 is read).
float ms_loss_avg(float perceptual_roughness) {
    int n_r = ms_size().y;
    float ty;
    int i = ms_cell(ms_r_coord(perceptual_roughness, n_r), n_r, ty) + ms_form() * n_r;
    float a = texelFetch(u_ms_table, ivec2(0, i), 0).g;
    float b = texelFetch(u_ms_table, ivec2(0, i + 1), 0).g;
    return (1.0 - ty) * a + ty * b;
}

// Kulla & Conty 2017: E(mu, r), the directional albedo with F = 1 of the single-scattering
// GGX specular with the material's G2 (brdf_eval's; integrated from its float64 twin,
// app/reference/multiscatter.py single_scatter_albedo).
float ms_E(float mu, float perceptual_roughness) {
    return 1.0 - ms_loss(mu, perceptual_roughness);
}

// Kulla & Conty 2017: E_avg(r) = 2 int_0^1 E(mu) mu dmu.
float ms_E_avg(float perceptual_roughness) {
    return 1.0 - ms_loss_avg(perceptual_roughness);
}

// The nodes of F_avg's quadrature: the midpoint rule in mu on F_AVG_NODES cells.
const int F_AVG_NODES = 16;

// Kulla & Conty 2017: F_avg = 2 int_0^1 F(mu) mu dmu, the hemispherical average of the exact
// Fresnel reflectance of a conductor of index eta + i k (Born & Wolf; fresnel.glsl), by the
// midpoint rule on 16 cells: F(mu) mu is smooth on [0, 1] for a conductor, so the error falls
// as 1/n^2 (at most 2e-4 for the metal presets against a 400-node Gauss-Legendre sum:
// tests/test_multiscatter.py). Schlick's F0 + (1 - F0)/21 from the base colour misses it by
// up to 0.066 (gold's blue: 0.375 for 0.441).
vec3 F_avg_conductor(vec3 eta, vec3 k) {
    vec3 sum = vec3(0.0);
    for (int i = 0; i < F_AVG_NODES; ++i) {
        float mu = (float(i) + 0.5) / float(F_AVG_NODES);
        sum += F_conductor(eta, k, mu) * mu;
    }
    return sum * (2.0 / float(F_AVG_NODES));
}

// The same average of the exact dielectric Fresnel reflectance (relative index eta): within
// 3.2e-4 for eta 1.33 to 2.4 (F rises fastest near grazing there).
float F_avg_dielectric(float eta) {
    float sum = 0.0;
    for (int i = 0; i < F_AVG_NODES; ++i) {
        float mu = (float(i) + 0.5) / float(F_AVG_NODES);
        sum += F_dielectric(eta, mu) * mu;
    }
    return sum * (2.0 / float(F_AVG_NODES));
}

// Kulla & Conty 2017: the lobe added to the single-scattering specular,
//   f_ms = (1 - E(n.l))(1 - E(n.v)) / (pi (1 - E_avg)) * F_avg^2 E_avg / (1 - F_avg (1 - E_avg)),
// F_avg the hemispherical average 2 int F mu dmu of the material's Fresnel (F_avg_selected in
// material.glsl). With F_avg = 1 the colour factor is exactly 1 and the lobe's albedo is
// 1 - E(n.l): f_spec + f_ms then reflects all light. The colour factor is the geometric
// series of bounces that each keep F_avg, so it is more saturated than F0.
// 1 - F_avg (1 - E_avg) >= E_avg > 0.4: no guard needed there.
vec3 f_ms_kulla_conty_F_avg(vec3 F_avg, float perceptual_roughness, float NoL, float NoV) {
    float loss_l = ms_loss(NoL, perceptual_roughness);
    float loss_v = ms_loss(NoV, perceptual_roughness);
    float loss_avg = ms_loss_avg(perceptual_roughness);
    vec3 colour = F_avg * F_avg * (1.0 - loss_avg) / (1.0 - F_avg * loss_avg);
    return colour * (loss_l * loss_v / (PI * max(loss_avg, MS_MIN_LOSS_AVG)));
}

// f_ms with Schlick's F: F_avg = F0 + (1 - F0)/21 (2 int_0^1 (1 - mu)^5 mu dmu = 1/21).
vec3 f_ms_kulla_conty(vec3 F0, float perceptual_roughness, float NoL, float NoV) {
    return f_ms_kulla_conty_F_avg(F0 + (1.0 - F0) / 21.0, perceptual_roughness, NoL, NoV);
}

#endif  // UBER_MODELS || MULTISCATTER

#endif
