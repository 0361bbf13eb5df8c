// Micro-cylinder (fibre) cloth models of RTR4 sec. 9.10: one thread per pixel along the
// tangent, whose scattering function replaces the base's specular and diffuse terms.
// Twin: app/reference/fiber.py. docs/cloth.md, section "Micro-cylinder", has the
// derivations and the measured numbers.
//
// Angles of a direction d about a thread of unit tangent t (Marschner et al. 2003's and
// Sadeghi et al. 2013's notation): the longitudinal angle theta in [-pi/2, pi/2] from the
// thread's normal plane, sin(theta) = t.d, cos(theta) = sqrt(1 - (t.d)^2) = sin(t, d); the
// azimuth phi about t, measured from the thread's normal n_k.
// theta_h = (theta_i + theta_r)/2, theta_d = (theta_i - theta_r)/2, phi_d = phi_i - phi_r.
#ifndef PBS_FIBER_GLSL
#define PBS_FIBER_GLSL

#include "common/constants.glsl"
#include "brdf/fresnel.glsl"

// Tangent samples along the thread (its curvature, fiber_curvature), midpoints of equal
// steps of the tilt in [-curvature, curvature]: Sadeghi et al. 2013 integrate a thread's
// tangent curve by a fixed set of samples; the twin measures how far 5 are from 256.
const int FIBER_SAMPLES = 5;
// The thread's radiance is weighted by cos(theta_i) (the curve radiance integral) where the
// illumination sum multiplies by n.l: the BRDF is that over n.l, with n.l floored here
// (below it a light's f (n.l) shrinks in proportion to n.l: at most 1e-4 of the irradiance).
const float FIBER_MIN_N_DOT_L = 1e-4;
// Floor of cos^2(theta_d), the factor Sadeghi et al. divide by (after Marschner et al.):
// it is 0 only where l and v both run along the thread in opposite senses (docs/cloth.md).
const float FIBER_MIN_COS2_THETA_D = 1e-4;
// Below this sum of the projection terms P the thread is not seen (f = 0).
const float FIBER_MIN_VISIBLE = 1e-12;
// Floor of the thread's longitudinal width gamma_s (= alpha, radians; 0.57 degrees): the
// thread direction carries float32 rounding (~1e-7 rad: the rotation about n, the tilts),
// which the lobe's flank, d ln g / d theta_h = theta_h / gamma_s^2, multiplies; at the
// roughness floor's 0.002 rad that was 2.7e-4 relative against the twin, at 0.01 it is
// below 1e-4 (tests/test_fiber.py).
const float FIBER_MIN_GAMMA_S = 0.01;
// Sadeghi et al. 2013, sec. 5: the width of the unit-height Gaussian u(phi_d) that blends
// the separable and the min form of the masking, 20 degrees.
const float FIBER_MASKING_WIDTH = 0.34906585;

// The thread direction: the orthonormal tangent t turned about n by `rotation` radians.
vec3 fiber_rotate(vec3 n, vec3 t, float rotation) {
    return cos(rotation) * t + sin(rotation) * cross(n, t);
}

// sin(x) and cos(x) of x = theta_i + theta_r and cos(theta_d), theta_d = (theta_i -
// theta_r)/2, from the sines s = t.d and cosines c = |t x d| of the two longitudinal
// angles. Precision: near the fibre's mirror cone (x ~ 0) sin(x) = s_i c_r + c_i s_r keeps
// an absolute error of ~1e-7, where 1 - cos(x) would keep none of x^2/2 in float32; and
// cos(theta_d) is half the length of (c_i + c_r, s_i + s_r), the sum of the two unit
// vectors at theta_i and theta_r, not sqrt((1 + cos(theta_i - theta_r))/2), which cancels
// where l and v run along the thread in opposite senses (6e-4 relative at cos^2 = 2e-4).
void fiber_angle_sums(float s_i, float c_i, float s_r, float c_r, out float sin_sum,
                      out float cos_sum, out float cos_td) {
    sin_sum = s_i * c_r + c_i * s_r;
    cos_sum = c_i * c_r - s_i * s_r;
    cos_td = 0.5 * length(vec2(c_i + c_r, s_i + s_r));
}

// ln(1 - y) for 0 <= y < 1: the series -(y + y^2/2 + y^3/3 + y^4/4) below y = 0.01
// (truncation <= y^4/5 relative: 2e-9), log(1 - y) above (GLSL has no log1p; log(1 - y) of
// a float32 y ~ 1e-6 would keep ~6 % of it).
float fiber_log1m(float y) {
    if (y < 0.01) return -y * (1.0 + y * (0.5 + y * (1.0 / 3.0 + y * 0.25)));
    return log(1.0 - y);
}

// atan(z) for |z| <= 1: reduced to |w| <= tan(pi/12) by atan(z) = pi/6 + atan((z sqrt 3 - 1)
// / (sqrt 3 + z)), then its Taylor series to w^15 (truncation w^17/17 < 1e-11).
// Precision: llvmpipe's atan is off by up to 3.3e-6 and its acos by 1.6e-4 (measured,
// tests/test_fiber.py), which the sharpest Gaussian lobe (gamma_s = 0.002) turns into a
// relative error of 1e-3; this one is within a few float32 ulps.
float fiber_atan_unit(float z) {
    float a = abs(z);
    bool big = a > 0.26794919;
    float w = big ? (a * 1.7320508 - 1.0) / (1.7320508 + a) : a;
    float w2 = w * w;
    float s = w * (1.0 + w2 * (-1.0 / 3.0 + w2 * (1.0 / 5.0 + w2 * (-1.0 / 7.0 + w2 * (1.0 / 9.0
            + w2 * (-1.0 / 11.0 + w2 * (1.0 / 13.0 + w2 * (-1.0 / 15.0))))))));
    float r = big ? PI / 6.0 + s : s;
    return z < 0.0 ? -r : r;
}

// atan2(y, x) in (-pi, pi] from fiber_atan_unit (0 for x = y = 0).
float fiber_atan2(float y, float x) {
    if (abs(y) <= abs(x)) {
        if (x == 0.0) return 0.0;
        float r = fiber_atan_unit(y / x);
        if (x < 0.0) r += y >= 0.0 ? PI : -PI;
        return r;
    }
    return (y > 0.0 ? 0.5 * PI : -0.5 * PI) - fiber_atan_unit(x / y);
}

// --- Kajiya & Kay 1989, "Rendering Fur with Three Dimensional Textures" ---

// Gamma(x + 1/2) / Gamma(x) for x >= 0.5: the recurrence G(x) = G(x + 4) prod (x + j) /
// (x + j + 1/2) and the asymptotic series of G(x + 4) to 1/x^5 (relative error <= 6e-8
// against lgamma over p = 1e-3 .. 1e5, tests/test_fiber.py).
float fiber_gamma_ratio(float x) {
    float prod = 1.0;
    for (int j = 0; j < 4; ++j) {
        prod *= (x + float(j)) / (x + float(j) + 0.5);
    }
    float y = x + 4.0;
    float r = 1.0 / y;
    float series = 1.0 + r * (-1.0 / 8.0 + r * (1.0 / 128.0 + r * (5.0 / 1024.0
                 + r * (-21.0 / 32768.0 + r * (-399.0 / 262144.0)))));
    return sqrt(y) * series * prod;
}

// The exponent p of the highlight from the thread's longitudinal width gamma_s (= alpha,
// fiber_gamma_s): cos^p(2 theta_h) ~ exp(-2 p theta_h^2) is the Gaussian in theta_h of
// standard deviation 1/(2 sqrt(p)); p = 1/(4 gamma_s^2) gives it width gamma_s, as
// Sadeghi's g(gamma_s, theta_h), so the two models' highlights match at equal roughness.
float kajiya_kay_exponent(float gamma_s) {
    return 0.25 / (gamma_s * gamma_s);
}

// Normalisation of the highlight (our derivation; Kajiya & Kay's k_s has none). The
// illumination sum's f (n.l) is k_s N cos^p(theta_i + theta_r)+ (Kajiya & Kay's highlight
// has no irradiance factor). For a thread in the surface plane the upper hemisphere is
// theta_i in (-pi/2, pi/2), phi_i in (0, pi), dl = cos(theta_i) dtheta_i dphi_i, so the
// directional albedo is
//   R(v) = k_s N pi int cos^p(theta_i + theta_r)+ cos(theta_i) dtheta_i <= k_s N pi I_(p+1),
//   I_q = int_{-pi/2}^{pi/2} cos^q x dx = sqrt(pi) Gamma((q + 1)/2) / Gamma(q/2 + 1),
// the maximum at theta_r = 0 (the correlation of two symmetric log-concave functions peaks
// at 0). N = 1/(pi I_(p+1)) = G((p + 2)/2) / pi^(3/2) makes the largest albedo k_s.
float kajiya_kay_normalization(float p) {
    return fiber_gamma_ratio(0.5 * (p + 2.0)) * (INV_PI * inversesqrt(PI));
}

// Kajiya & Kay's highlight cos^p(theta_i + theta_r)+, the angle between v and the cone of
// mirror directions of l about the thread: with l, v both leaving the surface that cosine
// is sin(t, l) sin(t, v) - (t.l)(t.v) = cos(theta_i + theta_r). As exp(p ln cos), with
// ln cos = ln(1 - sin^2)/2 from sin(theta_i + theta_r) while sin^2 < 1/2: the sine's
// absolute error (~2e-7) then moves p ln cos by p sin 2e-7, where log(cos) would move it by
// p 2e-7 (5e-4 relative on the tail of p = 2,500, measured); log(cos) beyond.
float kajiya_kay_highlight(float p, float sin_sum, float cos_sum) {
    if (cos_sum <= 0.0) return 0.0;
    float y = sin_sum * sin_sum;
    float ln_cos = y < 0.5 ? 0.5 * fiber_log1m(y) : log(cos_sum);
    return exp(p * ln_cos);
}

// --- Sadeghi, Bisker, De Deken & Jensen 2013, "A Practical Microcylinder Appearance Model
// for Cloth Rendering" (ACM TOG 32(2)), sec. 4-5 ---

// The unit-area Gaussian g(gamma, x) = exp(-x^2 / (2 gamma^2)) / (gamma sqrt(2 pi)).
float fiber_gaussian(float gamma, float x) {
    return exp(-0.5 * (x * x) / (gamma * gamma)) / (gamma * sqrt(2.0 * PI));
}

// d's component perpendicular to `axis`, normalised; zero where d runs along the axis.
vec3 fiber_project(vec3 axis, vec3 d) {
    vec3 p = d - axis * dot(axis, d);
    float len2 = dot(p, p);
    return len2 > 1e-12 ? p * inversesqrt(len2) : vec3(0.0);
}

// Sadeghi et al.'s shadowing-masking of two projected directions pi, pr about an axis, seen
// from the thread normal n_k: m = max(n_k.p, 0) each, blended by the unit-height Gaussian
// u(phi_d) of width FIBER_MASKING_WIDTH between the separable (uncorrelated) product and
// the min (fully correlated, phi_d = 0):  (1 - u) m_i m_r + u min(m_i, m_r). Used with the
// thread's tangent as axis (M, the azimuths phi) and with the surface bitangent (P, the
// projection term, the angles psi in the plane of the thread's tangent and normal).
float fiber_masking(vec3 n_k, vec3 pi, vec3 pr) {
    float m_i = max(dot(n_k, pi), 0.0);
    float m_r = max(dot(n_k, pr), 0.0);
    float phi_d = fiber_atan2(length(cross(pi, pr)), dot(pi, pr));
    float x = phi_d / FIBER_MASKING_WIDTH;
    float u = exp(-0.5 * x * x);
    return (1.0 - u) * m_i * m_r + u * min(m_i, m_r);
}

// The thread's scattering function f_s (Sadeghi et al. 2013, eq. 2-4) at one tangent, apart:
//   surface = F_r(eta, cos theta_d cos(phi_d/2)) cos(phi_d/2) g(gamma_s, theta_h) / cos^2 theta_d
//   volume  = F_t^2 ((1 - k_d) g(gamma_v, theta_h) + k_d) / (cos theta_i + cos theta_r)
//             / cos^2 theta_d                                      (times the albedo A)
// cos theta_d cos(phi_d/2) is the cosine of incidence on the cylinder's reflecting facet;
// cos(phi_d/2) = |p_i + p_r|/2 from the two unit projections (no cancellation near pi).
// F_t: our choice, both transmissions taken at that facet's angle, F_t^2 = (1 - F_r)^2
// (the paper's F_t(eta, w_i) F_t(eta', w_r') leaves the entry and exit points open).
// Both parts are symmetric in l and v (theta_h, cos theta_d and cos(phi_d/2) are).
void f_sadeghi_thread(float eta, float gamma_s, float gamma_v, float kd, float sin_sum,
                      float cos_sum, float cos_td, float c_i, float c_r, float cos_half_phi,
                      out float surface, out float volume) {
    float theta_h = 0.5 * fiber_atan2(sin_sum, cos_sum);
    float cos2_td = max(cos_td * cos_td, FIBER_MIN_COS2_THETA_D);
    float Fr = F_dielectric(eta, sqrt(cos2_td) * cos_half_phi);
    float Ft = 1.0 - Fr;
    surface = Fr * cos_half_phi * fiber_gaussian(gamma_s, theta_h) / cos2_td;
    float lobe = (1.0 - kd) * fiber_gaussian(gamma_v, theta_h) + kd;
    volume = Ft * Ft * lobe / (max(c_i + c_r, 1e-6) * cos2_td);
}

// --- the patch: one thread, its tangent curve sampled ---

// f_spec and f_diffuse of a fibre patch (the illumination sum multiplies them by n.l):
// one thread along t (unit, perpendicular to n) covering the patch, tilted about the
// bitangent b = n x t by FIBER_SAMPLES tilts tau_k in [-curvature, curvature]
// (t_k = cos tau t + sin tau n, n_k = cos tau n - sin tau t). Per tangent:
//   sadeghi = false, Kajiya & Kay (gamma_s sets the exponent):
//     f_spec (n.l) = mean_k F0 N_p cos^p(theta_i + theta_r)+,
//     f_diff (n.l) = mean_k rho 2/pi^2 cos theta_i   (= rho sin(t_k, l) 2/pi^2; the 2/pi^2
//       makes the albedo rho for a flat thread: int sin(t, l) dl = pi^2/2 over the hemisphere)
//   sadeghi = true (Sadeghi et al. 2013 sec. 5, one thread, a = 1: no gaps):
//     f (n.l) = sum_k f_s(t_k) M_k P_k cos theta_i / sum_k P_k,
//     the surface part in f_spec, the volume part times A = rho in f_diffuse.
// Both are divided by max(n.l, FIBER_MIN_N_DOT_L); gamma_s is floored at FIBER_MIN_GAMMA_S. Left out: the weave (two threads and
// their coverage a_1, a_2, the gaps' term of Q, the tiling of the weave pattern).
void f_fiber(bool sadeghi, vec3 n, vec3 t, vec3 l, vec3 v, float NoL, vec3 rho, vec3 F0,
             float eta, float gamma_s, float curvature, float gamma_v, float kd,
             out vec3 f_spec, out vec3 f_diffuse) {
    gamma_s = max(gamma_s, FIBER_MIN_GAMMA_S);
    vec3 b = cross(n, t);
    float p = kajiya_kay_exponent(gamma_s);
    float norm = kajiya_kay_normalization(p);
    vec3 pl_b = fiber_project(b, l);
    vec3 pv_b = fiber_project(b, v);
    float spec = 0.0;
    float diff = 0.0;
    float visible = 0.0;
    for (int k = 0; k < FIBER_SAMPLES; ++k) {
        float tau = curvature * ((2.0 * float(k) + 1.0) / float(FIBER_SAMPLES) - 1.0);
        float ct = cos(tau);
        float st = sin(tau);
        vec3 t_k = ct * t + st * n;
        vec3 n_k = ct * n - st * t;
        float s_i = clamp(dot(t_k, l), -1.0, 1.0);
        float s_r = clamp(dot(t_k, v), -1.0, 1.0);
        // cos(theta) = |t_k x d|, not sqrt(1 - s^2): that cancels for d along the thread
        // (1.2e-4 relative at cos(theta) = 0.02 measured).
        float c_i = min(length(cross(t_k, l)), 1.0);
        float c_r = min(length(cross(t_k, v)), 1.0);
        float sin_sum, cos_sum, cos_td;
        fiber_angle_sums(s_i, c_i, s_r, c_r, sin_sum, cos_sum, cos_td);
        if (!sadeghi) {
            spec += norm * kajiya_kay_highlight(p, sin_sum, cos_sum);
            diff += (2.0 * INV_PI * INV_PI) * c_i;
            continue;
        }
        vec3 pl = fiber_project(t_k, l);
        vec3 pv = fiber_project(t_k, v);
        float M = fiber_masking(n_k, pl, pv);
        float P = fiber_masking(n_k, pl_b, pv_b);
        float surface, volume;
        f_sadeghi_thread(eta, gamma_s, gamma_v, kd, sin_sum, cos_sum, cos_td, c_i, c_r,
                         0.5 * length(pl + pv), surface, volume);
        float w = M * P * c_i;
        spec += surface * w;
        diff += volume * w;
        visible += P;
    }
    float inv_nol = 1.0 / max(NoL, FIBER_MIN_N_DOT_L);
    if (!sadeghi) {
        float scale = inv_nol / float(FIBER_SAMPLES);
        f_spec = F0 * (spec * scale);
        f_diffuse = rho * (diff * scale);
        return;
    }
    // A view that sees (almost) none of the thread: 0. Guard: with v in the tangent plane a
    // float32 denormal P made inv_nol / P overflow and 0 * Inf a NaN.
    float scale = visible > FIBER_MIN_VISIBLE ? inv_nol / visible : 0.0;
    f_spec = vec3(spec * scale);
    f_diffuse = rho * (diff * scale);
}

#endif
