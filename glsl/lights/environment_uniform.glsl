// A uniform environment of radiance L, integrated exactly per pixel (docs/ibl.md, "The
// uniform environment"): L_o(v) = L R(v), with the directional albedo
//   R(v) = integral over the sphere of f(l, v) (n.l)+ dl                   (RTR4 sec. 9.3)
// of the pixel's whole BRDF (brdf_eval, every model: exact Fresnel, thin film, sheen,
// clear coat, anisotropy, every NDF and diffuse model, the Kulla-Conty lobe) by a fixed,
// deterministic quadrature in the pixel's own shading frame: the same Hammersley set for
// every pixel, mapped through each strategy's importance sampling; the surface reflection
// combined by Veach's balance heuristic (Veach 1997, "Robust Monte Carlo Methods for Light Transport
// Simulation", sec. 9.2, multi-sample estimator with equal counts):
//   R ~ sum_k sum_j g(l_kj) / (m sum_k' pdf_k'(l_kj)),   g = f (n.l)+,
// strategies: GGX visible normals with the pixel's alpha_x, alpha_y (Heitz 2018, "Sampling
// the GGX Distribution of Visible Normals"; for every NDF), cosine-weighted directions
// (diffuse and sheen) and, only where a clear coat is compiled in, GGX visible normals of
// the coat's roughness about the coat's normal. The subsurface (diffuse) lobe is taken by
// the cosine directions alone, which integrate Lambert exactly. No noise: R varies smoothly with n.v and
// roughness, and a mirror-smooth surface gives F(n.v) (the VNDF estimate is F G2/G1(v)).
// Twin: app/reference/environment_uniform.py (same function names).
#ifndef PBS_LIGHTS_ENVIRONMENT_UNIFORM_GLSL
#define PBS_LIGHTS_ENVIRONMENT_UNIFORM_GLSL

#include "common/constants.glsl"
#include "brdf/material.glsl"

// Hammersley point i of m: ((i + 1/2) / m, the base-2 radical inverse of i). The radical
// inverse reverses i's 32 bits (Warren's swaps), scaled by 2^-32.
vec2 hammersley(int i, int m) {
    uint b = uint(i);
    b = (b << 16u) | (b >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    return vec2((float(i) + 0.5) / float(m), float(b) * 2.3283064365386963e-10);
}

// A visible normal of the GGX distribution for the local view v (z along n, v.z > 0),
// alpha_x along x: Heitz 2018, listing 1 (stretch, sample the projected hemisphere's disc
// with its half warped by V_h.z, unstretch).
vec3 sample_ggx_vndf(vec3 v, float alpha_x, float alpha_y, vec2 u) {
    vec3 vh = normalize(vec3(alpha_x * v.x, alpha_y * v.y, v.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 T1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 T2 = cross(vh, T1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float t1 = r * cos(phi);
    float t2 = r * sin(phi);
    float w = 0.5 * (1.0 + vh.z);
    t2 = (1.0 - w) * sqrt(max(1.0 - t1 * t1, 0.0)) + w * t2;
    vec3 nh = t1 * T1 + t2 * T2 + sqrt(max(1.0 - t1 * t1 - t2 * t2, 0.0)) * vh;
    return normalize(vec3(alpha_x * nh.x, alpha_y * nh.y, max(nh.z, 0.0)));
}

// The density over directions l of reflecting v about a GGX visible normal (Heitz 2018,
// eq. 17 and the reflection's Jacobian 1/(4 v.h)): D(h) G1(v) / (4 v.z), with Smith's G1
// = 1/(1 + Lambda(v)) of the anisotropic GGX; 0 where h is below the surface.
float ggx_vndf_pdf(vec3 v, vec3 l, float alpha_x, float alpha_y) {
    vec3 h = normalize(v + l);
    if (h.z <= 0.0) return 0.0;
    vec3 hs = vec3(h.x / alpha_x, h.y / alpha_y, h.z);
    float q = dot(hs, hs);
    float D = 1.0 / (PI * alpha_x * alpha_y * q * q);
    float s2 = (alpha_x * alpha_x * v.x * v.x + alpha_y * alpha_y * v.y * v.y) / (v.z * v.z);
    float lambda = 0.5 * (sqrt(1.0 + s2) - 1.0);
    return D / (4.0 * (1.0 + lambda) * v.z);
}

// The cosine directions' azimuth offset for m points: half the finest azimuth step of their
// radical inverses, 1/2^ceil(log2 m), so that no point lies in the plane of v and its
// mirror direction, where the isotropic frame puts a narrow lobe's peak.
float cosine_phase(int m) {
    return 0.5 / exp2(ceil(log2(float(m))));
}

// A cosine-weighted direction about z (Malley's method: the unit disc lifted to the
// hemisphere), density z / pi, its azimuth turned by 2 pi phase.
vec3 sample_cosine(vec2 u, float phase) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * (u.y + phase);
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// An orthonormal frame (x, y, z = n) for the quadrature: x along the tangent the BRDF
// uses where the lobe is anisotropic, else along v's projection on the surface, so that an
// isotropic BRDF's R(v) depends on n.v alone (any perpendicular where v is along n).
mat3 environment_frame(vec3 n, vec3 t, vec3 v, bool anisotropic) {
    vec3 x = orthonormal_tangent(n, anisotropic ? t : v);
    return mat3(x, cross(n, x), n);
}

// v in a frame, lifted to at least MIN_N_DOT_V above its horizon (the BRDF clamps n.v
// the same way; interpolated normals can face away from the eye).
vec3 environment_local_view(mat3 frame, vec3 v) {
    vec3 local = v * frame;   // (x.v, y.v, n.v)
    local.z = max(local.z, MIN_N_DOT_V);
    return normalize(local);
}

// g(l) = f(l, v) (n.l)+ at the point sp as the lights take it (lights/illumination.glsl:
// brdf_eval, or with a coat normal of its own, GBUFFER_COAT_NORMAL, each layer with its
// own cosine, as brdf_eval_layered_cos), apart: the subsurface lobe's part d and the
// surface reflection's part r (RTR4 sec. 9.1), each as selected_terms keeps it; d + r is
// brdf_eval (n.l)+.
void environment_integrand(ShadingPoint sp, vec3 l, out vec3 d, out vec3 r) {
    d = vec3(0.0);
    r = vec3(0.0);
    float NoL = dot(sp.n, l);
#if GBUFFER_COAT_NORMAL && CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE) {
        float NoLc = dot(sp.nc, l);
        if (NoL <= 0.0 && NoLc <= 0.0) return;
        BrdfFactors b = brdf_factors(sp, l);
        if (NoL > 0.0) {
            d = selected_terms(b.f_diffuse, vec3(0.0)) * NoL;
            r = selected_terms(vec3(0.0), b.f_spec) * NoL;
        }
        float coat = (BRDF_TERMS & TERM_SPECULAR) != 0 ? b.f_coat : 0.0;
        if (NoLc > 0.0) r += vec3(coat * NoLc);
        return;
    }
#endif
    if (NoL <= 0.0) return;
    BrdfFactors b = brdf_factors(sp, l);
    d = selected_terms(b.f_diffuse, vec3(0.0)) * NoL;
    r = selected_terms(vec3(0.0), surface_reflection(b)) * NoL;
}

// R(v) of the point's BRDF by `count` directions in all (count / strategies each): the
// subsurface lobe by the cosine directions alone (exact for Lambert), the surface
// reflection by every strategy with the balance heuristic.
vec3 uniform_environment_albedo(ShadingPoint sp, int count) {
    Surface s = sp.s;
    ModelParams p = sp.params;
    vec3 n = sp.n;
    vec3 nc = sp.nc;
    vec3 t = sp.t;
    vec3 v = sp.v;
    bool anisotropic = ANISOTROPIC != 0 && s.anisotropy != 0.0;
    float alpha = material_alpha(s);
    float alpha_min = MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS;
    float alpha_x = anisotropic ? max(alpha * (1.0 + s.anisotropy), alpha_min) : alpha;
    float alpha_y = anisotropic ? max(alpha * (1.0 - s.anisotropy), alpha_min) : alpha;
    mat3 frame = environment_frame(n, t, v, anisotropic);
    vec3 v_local = environment_local_view(frame, v);
    int strategies = 2;
#if CLEARCOAT_ON
    // the coat's lobe: GGX visible normals of its roughness about its own normal
    bool coat = CLEARCOAT_MODEL != CLEARCOAT_NONE && p.clearcoat > 0.0;
    float rc = max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    float alpha_c = rc * rc;
    mat3 frame_c = environment_frame(nc, t, v, false);
    vec3 v_coat = environment_local_view(frame_c, v);
    if (coat) strategies = 3;
#endif
    int m = max(count / strategies, 1);
    float phase = cosine_phase(m);
    vec3 sum = vec3(0.0);
    int i = 0;
    do {  // bottom-tested (lights/illumination.glsl says why)
        vec2 u = hammersley(i, m);
        int k = 0;
        do {
            vec3 l = n;
            if (k == 0) {
                l = frame * reflect(-v_local, sample_ggx_vndf(v_local, alpha_x, alpha_y, u));
            } else if (k == 1) {
                l = frame * sample_cosine(u, phase);
            } else {
#if CLEARCOAT_ON
                l = frame_c * reflect(-v_coat, sample_ggx_vndf(v_coat, alpha_c, alpha_c, u));
#endif
            }
            vec3 d, r;
            environment_integrand(sp, l, d, r);
            vec3 l_local = l * frame;
            float pdf_cos = max(l_local.z, 0.0) * INV_PI;
            if (max(r.r, max(r.g, r.b)) > 0.0) {
                float pdf = ggx_vndf_pdf(v_local, l_local, alpha_x, alpha_y) + pdf_cos;
#if CLEARCOAT_ON
                if (coat) pdf += ggx_vndf_pdf(v_coat, l * frame_c, alpha_c, alpha_c);
#endif
                sum += r / (float(m) * pdf);
            }
            if (k == 1) sum += d / (float(m) * pdf_cos);  // the subsurface lobe: cosine only
        } while (++k < strategies);
    } while (++i < m);
    return sum;
}

#if ENVIRONMENT_UNIFORM
uniform vec3 u_env_radiance;   // the environment's radiance L (linear RGB)

// L R(v): the uniform environment's light reflected towards v, added once per pixel by
// the lighting pass (and the blend pass) where ENVIRONMENT_UNIFORM, with
// ENV_UNIFORM_SAMPLES directions (the scene's environment.samples).
vec3 uniform_environment_radiance(ShadingPoint sp) {
    return u_env_radiance * uniform_environment_albedo(sp, ENV_UNIFORM_SAMPLES);
}
#endif

#endif
