"""Twin of glsl/brdf/masking.glsl: Smith Lambda, G1 and the joint G2.

Same names, arguments, branches and quadrature nodes as the GLSL, in float64. Where the
GLSL approximates a special function (erfc, Gamma ratios, expm1, sinh) the twin uses the
exact one, so a GLSL-vs-twin difference measures float32 rounding plus that approximation.
The quadrature Lambdas (Blinn-Phong, GTR) are the GLSL's rules, not the exact integrals:
tests/test_microfacet.py measures how far they are from the truth.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from app.reference._vec import dot
from app.reference.ndf import gtr_peak

# Beyond this a = 1/(alpha tan theta) Beckmann's Lambda is < 1e-38 and the GLSL returns 0.
BECKMANN_A_CUTOFF = 9.0
# |n x l|^2 below which azimuth_difference calls a direction parallel to n (1e-4 rad).
AZIMUTH_PARALLEL_SIN2 = 1e-8


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def gauss_legendre_01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n-point Gauss-Legendre rule on [0, 1]: the GLSL's GL8_X/W and GL12_X/W."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


GL8_X, GL8_W = gauss_legendre_01(8)
GL12_X, GL12_W = gauss_legendre_01(12)


# --- GGX -------------------------------------------------------------------------------------


def Lambda_GGX(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Heitz 2014 eq. 72: Lambda = (sqrt(1 + alpha^2 tan^2 theta) - 1)/2.

    In the GLSL's cancellation-free form alpha^2 s^2 / (2 c (sqrt(c^2 + alpha^2 s^2) + c)).
    """
    c = _f64(cos_theta)
    a2s2 = _f64(alpha) ** 2 * (1.0 - c) * (1.0 + c)
    with np.errstate(divide="ignore"):
        return 0.5 * a2s2 / (c * (np.sqrt(c * c + a2s2) + c))


def G1_smith(Lambda_v: np.ndarray) -> np.ndarray:
    """Smith 1967; RTR4 §9.7: G1 = 1/(1 + Lambda(v)) (for m.v > 0)."""
    return 1.0 / (1.0 + _f64(Lambda_v))


def G2_height_correlated_GGX(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Heitz 2014 eq. 99; RTR4 §9.7: G2 = 1/(1 + Lambda(v) + Lambda(l))."""
    return 1.0 / (1.0 + Lambda_GGX(NoL, alpha) + Lambda_GGX(NoV, alpha))


def V_height_correlated_GGX(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """G2/(4 |n.l| |n.v|) for the height-correlated GGX G2, in the division-free form."""
    NoL = _f64(NoL)
    NoV = _f64(NoV)
    a2 = _f64(alpha) ** 2
    lambda_v = NoL * np.sqrt(NoV * NoV * (1.0 - a2) + a2)
    lambda_l = NoV * np.sqrt(NoL * NoL * (1.0 - a2) + a2)
    with np.errstate(divide="ignore"):
        return 0.5 / (lambda_v + lambda_l)


def V_hammon_GGX(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Hammon 2017: V ~ 0.5 / mix(2 n.l n.v, n.l + n.v, alpha), a fit of the height-correlated V."""
    NoL = _f64(NoL)
    NoV = _f64(NoV)
    a = _f64(alpha)
    with np.errstate(divide="ignore"):
        return 0.5 / ((1.0 - a) * (2.0 * NoL * NoV) + a * (NoL + NoV))


# --- Beckmann --------------------------------------------------------------------------------

_erfc = np.vectorize(math.erfc, otypes=[np.float64])


def erfc(x: np.ndarray) -> np.ndarray:
    """The exact complementary error function (the GLSL fits an approximation)."""
    return _erfc(_f64(x))


def erfcx(x: np.ndarray) -> np.ndarray:
    """e^(x^2) erfc(x), exact for 0 <= x <= 26 (beyond, its asymptotic series to x^-8)."""
    x = _f64(x)
    small = np.minimum(x, 26.0)
    direct = np.exp(small * small) * _erfc(small)
    big = np.maximum(x, 26.0)
    r = 1.0 / (2.0 * big * big)
    asymptotic = (1.0 - r * (1.0 - 3.0 * r * (1.0 - 5.0 * r))) / (big * math.sqrt(math.pi))
    return np.where(x <= 26.0, direct, asymptotic)


def _beckmann_a(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """a = 1/(alpha tan theta) = c/(alpha sqrt(1 - c^2)), +inf at c = 1."""
    c = _f64(cos_theta)
    s = np.sqrt((1.0 - c) * (1.0 + c))
    with np.errstate(divide="ignore", invalid="ignore"):
        return c / (_f64(alpha) * s)


def Lambda_beckmann(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Beckmann's exact Smith Lambda: (erf(a) - 1)/2 + e^(-a^2)/(2 a sqrt(pi)).

    Evaluated as (e^(-a^2)/(a sqrt(pi)) - erfc(a))/2 with the exact erfc: in float64 the
    residual cancellation costs ~2 a^2 ulps, < 2e-14 below the GLSL's cut-off a = 9, where
    both return 0 (Lambda < 1e-38).
    """
    a = _beckmann_a(cos_theta, alpha)
    finite = np.where(a < BECKMANN_A_CUTOFF, a, 1.0)
    with np.errstate(divide="ignore"):
        lam = 0.5 * (np.exp(-finite * finite) / (finite * math.sqrt(math.pi)) - erfc(finite))
    return np.where(a < BECKMANN_A_CUTOFF, lam, 0.0)


def Lambda_beckmann_rational(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Walter et al. 2007: (1 - 1.259a + 0.396a^2)/(3.535a + 2.181a^2) for a < 1.6, else 0."""
    a = _beckmann_a(cos_theta, alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
    return np.where(a < 1.6, lam, 0.0)


# --- Lambda of any isotropic NDF by quadrature -----------------------------------------------


def gamma_ratio_half(x: np.ndarray) -> np.ndarray:
    """Gamma(x + 1/2)/Gamma(x), exact (the GLSL shifts x to >= 8 and sums DLMF 5.11.13)."""
    lg = np.vectorize(math.lgamma, otypes=[np.float64])
    x = _f64(x)
    return np.exp(lg(x + 0.5) - lg(x))


def Lambda_blinn_phong(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Blinn-Phong's exact Smith Lambda by the GLSL's 12-point rule.

    The slopes of Blinn-Phong are Student-t distributed with nu = alpha_p + 2 = 2/alpha^2, so
    Lambda = R(nu)/((nu - 1) c) integral_c^1 (1 - c^2/x^2)^(nu/2 - 1) dx, R(nu) =
    Gamma((nu + 1)/2)/(sqrt(pi) Gamma(nu/2)); with x = c e^u, u = ln(1/c) s^k, k = max(1, 4/nu).
    """
    c, alpha = np.broadcast_arrays(_f64(cos_theta), _f64(alpha))
    inside = (c > 0.0) & (c < 1.0)
    cc = np.where(inside, c, 0.5)
    nu = 2.0 / alpha**2
    Y = -np.log(cc)
    k = np.maximum(1.0, 4.0 / nu)
    total = np.zeros(c.shape)
    for x, w in zip(GL12_X, GL12_W, strict=True):
        sk = x**k
        u = Y * sk
        ln_h = (0.5 * nu - 1.0) * np.log(-np.expm1(-2.0 * u))
        total = total + w * np.exp(ln_h + u) * sk / x
    lam = gamma_ratio_half(0.5 * nu) / math.sqrt(math.pi) / (nu - 1.0) * Y * k * total
    return np.where(inside, lam, np.where(c >= 1.0, 0.0, np.inf))


def atan_accurate(x: np.ndarray) -> np.ndarray:
    """atan(x), x >= 0: exact here (the GLSL reduces and sums a series, llvmpipe's is 3.5e-6)."""
    return np.arctan(_f64(x))


def smith_kernel(sin_psi: np.ndarray, cos_psi: np.ndarray, kappa: np.ndarray) -> np.ndarray:
    """K = sin(psi)(sin(psi) - kappa cos(psi) atan(tan(psi)/kappa)), the GLSL's two branches.

    Where x = tan(psi)/kappa < 1/2, K = kappa sin cos (x - atan x) by the series through x^25.
    """
    s, c, kappa = np.broadcast_arrays(_f64(sin_psi), _f64(cos_psi), _f64(kappa))
    kc = kappa * c
    small = s < 0.5 * kc
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(small, s / np.where(small, kc, 1.0), 0.0)
    x2 = x * x
    series = np.zeros(x.shape)
    for j in range(12, 0, -1):  # 1/3 - x2 (1/5 - x2 (... - x2/25))
        series = 1.0 / (2 * j + 1) - x2 * series
    with np.errstate(divide="ignore"):
        big = s * (s - kc * atan_accurate(s / kc))
    return np.where(small, kc * s * x * x2 * series, big)


def Lambda_GTR(cos_theta: np.ndarray, alpha: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """GTR's exact Smith Lambda (Burley 2012's NDF) by the GLSL's 8 + 8-point rule.

    Lambda = 2 D(n) (alpha^2/B^2)^gamma sin^2 B^3/cos * integral_0^(pi/2) (cos^2 psi + B^2
    sin^2 psi)^(gamma - 2) K(psi) dpsi, B^2 = alpha^2 sin^2 + cos^2, kappa = cos/B; psi in
    [0, pi/4] directly, [pi/4, pi/2] through tan(pi/2 - psi) = B sinh(y).
    """
    c0, alpha, gamma = np.broadcast_arrays(_f64(cos_theta), _f64(alpha), _f64(gamma))
    inside = (c0 > 0.0) & (c0 < 1.0)
    c = np.where(inside, c0, 0.5)
    s2 = (1.0 - c) * (1.0 + c)
    a2 = alpha * alpha
    B2 = a2 * s2 + c * c
    B = np.sqrt(B2)
    kappa = c / B
    I_A = np.zeros(c.shape)
    for x, w in zip(GL8_X, GL8_W, strict=True):
        psi = 0.25 * np.pi * x
        sp, cp = np.sin(psi), np.cos(psi)
        I_A = I_A + w * smith_kernel(sp, cp, kappa) * (cp * cp + B2 * sp * sp) ** (gamma - 2.0)
    Y = np.arcsinh(1.0 / B)
    I_B = np.zeros(c.shape)
    for x, w in zip(GL8_X, GL8_W, strict=True):
        y = Y * x
        sh, ch = np.sinh(y), np.cosh(y)
        q = 1.0 + B2 * sh * sh
        rq = 1.0 / np.sqrt(q)
        weight = (B2 * ch * ch / q) ** (gamma - 2.0) * B * ch / q
        I_B = I_B + w * smith_kernel(rq, B * sh * rq, kappa) * weight
    scale = 2.0 * gtr_peak(alpha, gamma) * (a2 / B2) ** gamma * s2 * B2 * B / c
    lam = scale * (0.25 * np.pi * I_A + Y * I_B)
    return np.where(inside, lam, np.where(c0 >= 1.0, 0.0, np.inf))


# --- anisotropy and the azimuth between l and v ---------------------------------------------


def alpha_in_direction(
    t: np.ndarray, b: np.ndarray, s: np.ndarray, alpha_x: np.ndarray, alpha_y: np.ndarray
) -> np.ndarray:
    """Heitz 2014 eq. 80: sqrt(cos^2(phi) ax^2 + sin^2(phi) ay^2), phi = azimuth of s in (t, b).

    s parallel to n returns sqrt((ax^2 + ay^2)/2) (any finite value would do: Lambda = 0 there).
    """
    x, y = dot(t, s), dot(b, s)
    ax, ay = _f64(alpha_x), _f64(alpha_y)
    r = np.maximum(np.abs(x), np.abs(y))
    ok = r > 0.0
    rr = np.where(ok, r, 1.0)
    x, y = x / rr, y / rr
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.sqrt((x * x * ax * ax + y * y * ay * ay) / (x * x + y * y))
    return np.where(ok, a, np.sqrt(0.5 * (ax * ax + ay * ay)))


def azimuth_difference(n: np.ndarray, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """phi in [0, pi] between the tangent-plane projections of l and v; 0 if either is within
    1e-4 rad of n. phi = atan2(|(n x l) x (n x v)|, (n x l).(n x v)), as in the GLSL."""
    n, l, v = _f64(n), _f64(l), _f64(v)
    pl = np.cross(n, l)
    pv = np.cross(n, v)
    cr = np.cross(pl, pv)
    phi = np.arctan2(np.sqrt(dot(cr, cr)), dot(pl, pv))
    parallel = (dot(pl, pl) < AZIMUTH_PARALLEL_SIN2) | (dot(pv, pv) < AZIMUTH_PARALLEL_SIN2)
    return np.where(parallel, 0.0, phi)


def lambda_phi_exp(phi: np.ndarray) -> np.ndarray:
    """Ashikhmin et al. 2000 (RTR4 §9.7): lambda(phi) = 1 - e^(-7.3 phi^2)."""
    return -np.expm1(-7.3 * _f64(phi) ** 2)


def lambda_phi_rational(phi: np.ndarray) -> np.ndarray:
    """van Ginneken et al. 1998 (RTR4 §9.7): lambda(phi) = 4.41 phi/(4.41 phi + 1)."""
    phi = _f64(phi)
    return 4.41 * phi / (4.41 * phi + 1.0)


# --- the four joint masking-shadowing forms of RTR4 §9.7 ---------------------------------


def G2_separable(Lambda_v: np.ndarray, Lambda_l: np.ndarray) -> np.ndarray:
    """Walter et al. 2007: G2 = G1(v) G1(l)."""
    return G1_smith(Lambda_v) * G1_smith(Lambda_l)


def G2_height_correlated(Lambda_v: np.ndarray, Lambda_l: np.ndarray) -> np.ndarray:
    """Heitz 2014 eq. 99: G2 = 1/(1 + Lambda(v) + Lambda(l))."""
    return 1.0 / (1.0 + _f64(Lambda_v) + _f64(Lambda_l))


def G2_direction_correlated(
    Lambda_v: np.ndarray, Lambda_l: np.ndarray, lambda_phi: np.ndarray
) -> np.ndarray:
    """Ashikhmin et al. 2000: lambda G1(v) G1(l) + (1 - lambda) min(G1(v), G1(l))."""
    g_v, g_l = G1_smith(Lambda_v), G1_smith(Lambda_l)
    lam = _f64(lambda_phi)
    return np.minimum(g_v, g_l) * (1.0 - lam) + g_v * g_l * lam


def G2_height_direction_correlated(
    Lambda_v: np.ndarray, Lambda_l: np.ndarray, lambda_phi: np.ndarray
) -> np.ndarray:
    """Ross et al. 2005: 1/(1 + max(Lambda(v), Lambda(l)) + lambda min(Lambda(v), Lambda(l)))."""
    Lv, Ll, lam = np.broadcast_arrays(_f64(Lambda_v), _f64(Lambda_l), _f64(lambda_phi))
    with np.errstate(invalid="ignore"):
        low = np.where(lam > 0.0, lam * np.minimum(Lv, Ll), 0.0)  # no 0 * inf at phi = 0
    return 1.0 / (1.0 + np.maximum(Lv, Ll) + low)


# --- exact references for the tests and the documentation -----------------------------------


def Lambda_numeric(
    D_of_cos: Callable[[np.ndarray], np.ndarray],
    cos_theta: float,
    *,
    scale: float,
    n_psi: int = 64,
    panels: int = 12,
) -> float:
    """Smith Lambda of an isotropic NDF, independent of any closed form (for tests and docs).

    Lambda(v) = (1/cos) integral of D(m) (v.m)^- dm: the projected area of the microfacets
    that face away from v, which the visible ones must make up (RTR4 §9.7). The azimuthal
    integral of (v.m)^- is closed-form, 2 (b sin phi0 - a phi0) with a = cos_v cos_m,
    b = sin_v sin_m, cos phi0 = a/b; what remains is one integral over theta_m, taken in
    tan(theta_m) = scale tan(psi) from the cut theta_m = pi/2 - theta_v by composite
    Gauss-Legendre graded toward both ends. ``D_of_cos`` maps cos(theta_m) to D.
    """
    c = float(cos_theta)
    if c >= 1.0:
        return 0.0
    s = math.sqrt((1.0 - c) * (1.0 + c))
    psi0 = math.atan(c / (s * scale))  # tan(theta_m) = cot(theta_v): where the cut starts
    x, w = np.polynomial.legendre.leggauss(n_psi)
    grade = np.concatenate([[0.0], np.geomspace(4.0**-panels, 0.5, panels)])
    edges = np.unique(np.concatenate([grade, 1.0 - grade]))
    lo, hi = edges[:-1, None], edges[1:, None]
    u = (0.5 * (hi - lo) * (x + 1.0) + lo).ravel()
    wu = (0.5 * (hi - lo) * w).ravel()
    psi = psi0 + (0.5 * np.pi - psi0) * u
    wpsi = (0.5 * np.pi - psi0) * wu
    sp, cp = np.sin(psi), np.cos(psi)
    r = np.sqrt(cp * cp + scale * scale * sp * sp)
    cos_m, sin_m = cp / r, scale * sp / r
    dtheta = scale / (r * r)
    a, b = c * cos_m, s * sin_m
    phi0 = np.arccos(np.clip(a / b, -1.0, 1.0))
    back = 2.0 * (b * np.sin(phi0) - a * phi0)
    integrand = np.asarray(D_of_cos(cos_m), np.float64) * sin_m * back * dtheta
    return float(np.sum(integrand * wpsi) / c)
