"""Twin of glsl/brdf/fiber.glsl: the micro-cylinder (fibre) cloth models of RTR4 §9.10.

One thread per point along the tangent; its scattering replaces the base's specular and
diffuse terms. Kajiya & Kay 1989, "Rendering Fur with Three Dimensional Textures", and
Sadeghi, Bisker, De Deken & Jensen 2013, "A Practical Microcylinder Appearance Model for
Cloth Rendering" (ACM TOG 32(2)). Same names, same order of operations as the GLSL,
float64, broadcasting over the leading axes (directions have a last axis of 3).
docs/cloth.md, "Micro-cylinder", has the derivations and the measured numbers.

Angles of a direction d about a thread of unit tangent t: sin(theta) = t.d (theta from the
thread's normal plane), cos(theta) = sin(t, d); theta_h = (theta_i + theta_r)/2,
theta_d = (theta_i - theta_r)/2; phi the azimuth about t from the thread normal.
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot
from app.reference.constants import INV_PI, PI
from app.reference.fresnel import F_dielectric

# Tangent samples along a curved thread (GLSL: the same); the twin can take more
# (``samples``) to measure what five leave out.
FIBER_SAMPLES = 5
# The BRDF is the thread's cos(theta_i)-weighted radiance over n.l, floored here.
FIBER_MIN_N_DOT_L = 1e-4
# Floor of cos^2(theta_d) (0 only for l, v along the thread in opposite senses).
FIBER_MIN_COS2_THETA_D = 1e-4
# Below this sum of the projection terms P the thread is not seen (f = 0).
FIBER_MIN_VISIBLE = 1e-12
# Floor of the thread's longitudinal width gamma_s (radians): float32 rounding of the
# thread direction on the flank of a narrower lobe exceeds 1e-4 relative (see the GLSL).
FIBER_MIN_GAMMA_S = 0.01
# Sadeghi et al. 2013, sec. 5: width of u(phi_d) in the masking, 20 degrees.
FIBER_MASKING_WIDTH = np.radians(20.0)


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def fiber_rotate(n: np.ndarray, t: np.ndarray, rotation: float) -> np.ndarray:
    """The thread direction: the orthonormal tangent t turned about n by ``rotation`` rad."""
    n, t = _f64(n), _f64(t)
    return np.cos(rotation) * t + np.sin(rotation) * np.cross(n, t)


def fiber_angle_sums(
    s_i: np.ndarray, c_i: np.ndarray, s_r: np.ndarray, c_r: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sin, cos) of theta_i + theta_r and cos(theta_d) from the sines and cosines of the
    longitudinal angles; cos(theta_d) = |(c_i + c_r, s_i + s_r)|/2 (see the GLSL)."""
    cos_td = 0.5 * np.hypot(_f64(c_i) + c_r, _f64(s_i) + s_r)
    return s_i * c_r + c_i * s_r, c_i * c_r - s_i * s_r, cos_td


def fiber_log1m(y: np.ndarray) -> np.ndarray:
    """ln(1 - y), 0 <= y < 1: the GLSL's four-term series below 0.01, log(1 - y) above."""
    y = _f64(y)
    series = -y * (1.0 + y * (0.5 + y * (1.0 / 3.0 + y * 0.25)))
    with np.errstate(divide="ignore"):
        return np.where(y < 0.01, series, np.log(np.maximum(1.0 - y, 0.0)))


def fiber_atan2(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """atan2(y, x) (0 for x = y = 0). The GLSL evaluates its own reduced Taylor series
    (truncation < 1e-11): llvmpipe's atan is off by 3.3e-6, its acos by 1.6e-4."""
    return np.arctan2(_f64(y), _f64(x))


# --- Kajiya & Kay 1989 ---


def fiber_gamma_ratio(x: np.ndarray) -> np.ndarray:
    """Gamma(x + 1/2) / Gamma(x), x >= 0.5: four steps of the recurrence and the asymptotic
    series to 1/x^5 (<= 6e-8 relative, tests/test_fiber.py)."""
    x = _f64(x)
    prod = np.ones_like(x)
    for j in range(4):
        prod = prod * ((x + j) / (x + j + 0.5))
    y = x + 4.0
    r = 1.0 / y
    series = 1.0 + r * (-1.0 / 8.0 + r * (1.0 / 128.0 + r * (5.0 / 1024.0
             + r * (-21.0 / 32768.0 + r * (-399.0 / 262144.0)))))  # fmt: skip
    return np.sqrt(y) * series * prod


def kajiya_kay_exponent(gamma_s: np.ndarray) -> np.ndarray:
    """p = 1/(4 gamma_s^2): cos^p(2 theta_h) ~ exp(-2 p theta_h^2) then has the width
    gamma_s of Sadeghi's g(gamma_s, theta_h) (our mapping from roughness, gamma_s = alpha)."""
    gamma_s = _f64(gamma_s)
    return 0.25 / (gamma_s * gamma_s)


def kajiya_kay_normalization(p: np.ndarray) -> np.ndarray:
    """N = 1/(pi I_(p+1)) = G((p + 2)/2)/pi^(3/2), I_q = int cos^q over (-pi/2, pi/2):
    the highlight's largest directional albedo is then k_s (derivation in the GLSL)."""
    return fiber_gamma_ratio(0.5 * (_f64(p) + 2.0)) * (INV_PI / np.sqrt(PI))


def kajiya_kay_highlight(p: np.ndarray, sin_sum: np.ndarray, cos_sum: np.ndarray) -> np.ndarray:
    """cos^p(theta_i + theta_r)+ (Kajiya & Kay's sin(t,l) sin(t,v) - (t.l)(t.v) for l, v
    leaving the surface), as exp(p ln cos), ln cos = ln(1 - sin^2)/2 while sin^2 < 1/2."""
    y = _f64(sin_sum) ** 2
    cos_sum = _f64(cos_sum)
    with np.errstate(divide="ignore"):
        ln_cos = np.where(y < 0.5, 0.5 * fiber_log1m(y), np.log(np.maximum(cos_sum, 1e-300)))
    return np.where(cos_sum <= 0.0, 0.0, np.exp(_f64(p) * ln_cos))


# --- Sadeghi, Bisker, De Deken & Jensen 2013 ---


def fiber_gaussian(gamma: np.ndarray | float, x: np.ndarray) -> np.ndarray:
    """The unit-area Gaussian g(gamma, x) = exp(-x^2/(2 gamma^2)) / (gamma sqrt(2 pi))."""
    x = _f64(x)
    return np.exp(-0.5 * (x * x) / (gamma * gamma)) / (gamma * np.sqrt(2.0 * PI))


def fiber_project(axis: np.ndarray, d: np.ndarray) -> np.ndarray:
    """d's component perpendicular to ``axis``, normalised; zero along the axis."""
    axis, d = _f64(axis), _f64(d)
    p = d - axis * dot(axis, d)[..., None]
    len2 = dot(p, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = p / np.sqrt(len2)[..., None]
    return np.where((len2 > 1e-12)[..., None], unit, 0.0)


def fiber_masking(n_k: np.ndarray, pi: np.ndarray, pr: np.ndarray) -> np.ndarray:
    """Sadeghi et al.'s (1 - u(phi_d)) m_i m_r + u(phi_d) min(m_i, m_r), m = max(n_k.p, 0),
    u the unit-height Gaussian of width 20 degrees (M about the tangent, P about b)."""
    m_i = np.maximum(dot(n_k, pi), 0.0)
    m_r = np.maximum(dot(n_k, pr), 0.0)
    phi_d = fiber_atan2(np.linalg.norm(np.cross(pi, pr), axis=-1), dot(pi, pr))
    x = phi_d / FIBER_MASKING_WIDTH
    u = np.exp(-0.5 * x * x)
    return (1.0 - u) * m_i * m_r + u * np.minimum(m_i, m_r)


def f_sadeghi_thread(
    eta: float,
    gamma_s: float,
    gamma_v: float,
    kd: float,
    sin_sum: np.ndarray,
    cos_sum: np.ndarray,
    cos_td: np.ndarray,
    c_i: np.ndarray,
    c_r: np.ndarray,
    cos_half_phi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Sadeghi et al. 2013 eq. 2-4, the thread's f_s apart (surface, volume / A):
    F_r(eta, cos theta_d cos(phi_d/2)) cos(phi_d/2) g(gamma_s, theta_h) / cos^2 theta_d and
    (1 - F_r)^2 ((1 - k_d) g(gamma_v, theta_h) + k_d) / (cos theta_i + cos theta_r) /
    cos^2 theta_d; both transmissions at the reflecting facet's angle (our choice).
    ``cos_half_phi`` = cos(phi_d/2) = |p_i + p_r|/2."""
    theta_h = 0.5 * fiber_atan2(sin_sum, cos_sum)
    cos2_td = np.maximum(_f64(cos_td) ** 2, FIBER_MIN_COS2_THETA_D)
    cos_half_phi = _f64(cos_half_phi)
    Fr = F_dielectric(eta, np.sqrt(cos2_td) * cos_half_phi)
    Ft = 1.0 - Fr
    surface = Fr * cos_half_phi * fiber_gaussian(gamma_s, theta_h) / cos2_td
    lobe = (1.0 - kd) * fiber_gaussian(gamma_v, theta_h) + kd
    volume = Ft * Ft * lobe / (np.maximum(_f64(c_i) + c_r, 1e-6) * cos2_td)
    return surface, volume


def f_fiber(
    sadeghi: bool,
    n: np.ndarray,
    t: np.ndarray,
    l: np.ndarray,
    v: np.ndarray,
    NoL: np.ndarray,
    rho: np.ndarray,
    F0: np.ndarray,
    eta: float,
    gamma_s: np.ndarray | float,
    curvature: float,
    gamma_v: float,
    kd: float,
    samples: int = FIBER_SAMPLES,
) -> tuple[np.ndarray, np.ndarray]:
    """(f_spec, f_diffuse) of a fibre patch, (..., 3) each (see the GLSL ``f_fiber``): one
    thread along the unit t (perpendicular to n) tilted about b = n x t by ``samples``
    midpoint tilts in [-curvature, curvature]; Kajiya & Kay (``sadeghi`` false) the mean of
    F0 N_p cos^p(theta_i + theta_r)+ and rho 2/pi^2 cos(theta_i), Sadeghi et al. the
    P-weighted sum_k f_s M_k P_k cos(theta_i) / sum_k P_k; both over max(n.l, 1e-4);
    gamma_s floored at FIBER_MIN_GAMMA_S."""
    n, t, l, v = (_f64(x) for x in (n, t, l, v))
    b = np.cross(n, t)
    gamma_s = np.maximum(_f64(gamma_s), FIBER_MIN_GAMMA_S)
    p = kajiya_kay_exponent(gamma_s)
    norm = kajiya_kay_normalization(p)
    pl_b = fiber_project(b, l)
    pv_b = fiber_project(b, v)
    shape = np.broadcast_shapes(l.shape[:-1], v.shape[:-1], n.shape[:-1])
    spec = np.zeros(shape)
    diff = np.zeros(shape)
    visible = np.zeros(shape)
    for k in range(samples):
        tau = curvature * ((2.0 * k + 1.0) / samples - 1.0)
        ct, st = np.cos(tau), np.sin(tau)
        t_k = ct * t + st * n
        n_k = ct * n - st * t
        s_i = np.clip(dot(t_k, l), -1.0, 1.0)
        s_r = np.clip(dot(t_k, v), -1.0, 1.0)
        c_i = np.minimum(np.linalg.norm(np.cross(t_k, l), axis=-1), 1.0)  # |t_k x l|
        c_r = np.minimum(np.linalg.norm(np.cross(t_k, v), axis=-1), 1.0)
        sin_sum, cos_sum, cos_td = fiber_angle_sums(s_i, c_i, s_r, c_r)
        if not sadeghi:
            spec = spec + norm * kajiya_kay_highlight(p, sin_sum, cos_sum)
            diff = diff + (2.0 * INV_PI * INV_PI) * c_i
            continue
        pl = fiber_project(t_k, l)
        pv = fiber_project(t_k, v)
        M = fiber_masking(n_k, pl, pv)
        P = fiber_masking(n_k, pl_b, pv_b)
        surface, volume = f_sadeghi_thread(
            eta, gamma_s, gamma_v, kd, sin_sum, cos_sum, cos_td, c_i, c_r,
            0.5 * np.linalg.norm(pl + pv, axis=-1),
        )  # fmt: skip
        w = M * P * c_i
        spec = spec + surface * w
        diff = diff + volume * w
        visible = visible + P
    inv_nol = 1.0 / np.maximum(_f64(NoL), FIBER_MIN_N_DOT_L)
    rho, F0 = _f64(rho), _f64(F0)
    if not sadeghi:
        scale = inv_nol / samples
        return F0 * (spec * scale)[..., None], rho * (diff * scale)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(visible > FIBER_MIN_VISIBLE, inv_nol / visible, 0.0)
    return np.broadcast_to((spec * scale)[..., None], (*shape, 3)), rho * (diff * scale)[..., None]
