"""Twin of glsl/brdf/ndf.glsl: normal distribution functions.

Every D carries chi+(n.m) and is normalised, integral of D(m)(n.m) dm = 1 (RTR4 §9.7).
The twins evaluate the GLSL's formulas, clamps and branches in float64; where the GLSL
approximates a special function (expm1, log1p), the twin uses the exact numpy one, so a
GLSL-vs-twin difference measures float32 rounding plus that approximation.
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot

# Beckmann's exponent beyond which the GLSL returns 0 (exp(-87) is float32's normal floor).
BECKMANN_EXPONENT_CUTOFF = 87.0


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def expm1_over_x(x: np.ndarray) -> np.ndarray:
    """(e^x - 1)/x, 1 at x = 0: the stable building block of the GTR normalisation."""
    x = _f64(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x == 0.0, 1.0, np.expm1(x) / np.where(x == 0.0, 1.0, x))


def log_one_minus(x: np.ndarray) -> np.ndarray:
    """ln(1 - x) without cancellation for small x (the GLSL sums atanh's series there)."""
    return np.log1p(-_f64(x))


def D_GGX(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Walter et al. 2007 (GGX); Trowbridge & Reitz 1975; RTR4 §9.8.

    D(m) = chi+(n.m) alpha^2 / (pi (1 + (n.m)^2 (alpha^2 - 1))^2), with the denominator
    written as (n.m)^2 alpha^2 + |n x m|^2 exactly as the GLSL does.
    """
    NoM = dot(n, m)
    nxm = np.cross(_f64(n), _f64(m))
    a2 = _f64(alpha) ** 2
    d = NoM * NoM * a2 + dot(nxm, nxm)
    with np.errstate(divide="ignore", invalid="ignore"):
        D = a2 / (np.pi * d * d)
    return np.where(NoM > 0.0, D, 0.0)


def D_beckmann(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Beckmann & Spizzichino 1963; RTR4 eq. 9.35.

    D(m) = chi+(n.m) exp(((n.m)^2 - 1)/(alpha^2 (n.m)^2)) / (pi alpha^2 (n.m)^4), with
    (n.m)^2 - 1 = -|n x m|^2 and 0 beyond the exponent cut-off, as in the GLSL.
    """
    NoM = dot(n, m)
    nxm = np.cross(_f64(n), _f64(m))
    a2 = _f64(alpha) ** 2
    c2 = NoM * NoM
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = dot(nxm, nxm) / (a2 * c2)
        D = np.exp(-e) / (np.pi * a2 * c2 * c2)
    return np.where((NoM > 0.0) & (e <= BECKMANN_EXPONENT_CUTOFF), D, 0.0)


def blinn_phong_exponent(alpha: np.ndarray) -> np.ndarray:
    """Walter et al. 2007: alpha_p = 2/alpha^2 - 2, Blinn-Phong's exponent at Beckmann's alpha."""
    return 2.0 / _f64(alpha) ** 2 - 2.0


def D_blinn_phong(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Blinn 1977, normalised: D = chi+(n.m) (alpha_p + 2)/(2 pi) (n.m)^alpha_p.

    (n.m)^alpha_p = exp(alpha_p/2 ln(1 - |n x m|^2)) near the peak (|n x m|^2 < 1/4) and
    exp(alpha_p ln(n.m)) elsewhere, the GLSL's two branches.
    """
    NoM = dot(n, m)
    p = blinn_phong_exponent(alpha)
    nxm = np.cross(_f64(n), _f64(m))
    s2 = dot(nxm, nxm)
    with np.errstate(divide="ignore", invalid="ignore"):
        ln_c2 = np.where(
            s2 < 0.25, log_one_minus(np.minimum(s2, 0.25)), 2.0 * np.log(np.maximum(NoM, 1e-30))
        )
        D = (p + 2.0) / (2.0 * np.pi) * np.exp(0.5 * p * ln_c2)
    return np.where(NoM > 0.0, D, 0.0)


def gtr_peak(alpha: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """D_GTR(n) = c alpha^(-2 gamma) = E(L)/(pi alpha^2 E((gamma - 1) L)), L = ln alpha^2.

    Burley 2012's c = (gamma - 1)(alpha^2 - 1)/(pi (1 - alpha^(2(1 - gamma)))) rewritten with
    E(x) = (e^x - 1)/x: no 0/0 at gamma = 1 (the log form) or alpha = 1 (D = 1/pi).
    """
    a2 = _f64(alpha) ** 2
    L = np.log(a2)
    return expm1_over_x(L) / (np.pi * a2 * expm1_over_x((_f64(gamma) - 1.0) * L))


def D_GTR(n: np.ndarray, m: np.ndarray, alpha: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Burley 2012, appendix B: D = c / (alpha^2 (n.m)^2 + 1 - (n.m)^2)^gamma, chi+(n.m).

    Evaluated as gtr_peak / d^gamma with d = (n.m)^2 + |n x m|^2/alpha^2 in [1, 1/alpha^2].
    """
    NoM = dot(n, m)
    nxm = np.cross(_f64(n), _f64(m))
    d = NoM * NoM + dot(nxm, nxm) / _f64(alpha) ** 2
    with np.errstate(over="ignore", divide="ignore"):
        D = gtr_peak(alpha, gamma) / d ** _f64(gamma)
    return np.where(NoM > 0.0, D, 0.0)


def D_GGX_aniso(
    n: np.ndarray,
    t: np.ndarray,
    b: np.ndarray,
    m: np.ndarray,
    alpha_x: np.ndarray,
    alpha_y: np.ndarray,
) -> np.ndarray:
    """Anisotropic GGX (RTR4 eqs. 9.37-9.38): 1/(pi ax ay ((t.m/ax)^2 + (b.m/ay)^2 + (n.m)^2)^2)."""
    NoM = dot(n, m)
    ax, ay = _f64(alpha_x), _f64(alpha_y)
    x = dot(t, m) / ax
    y = dot(b, m) / ay
    d = x * x + y * y + NoM * NoM
    with np.errstate(divide="ignore"):
        D = 1.0 / (np.pi * ax * ay * d * d)
    return np.where(NoM > 0.0, D, 0.0)


def D_beckmann_aniso(
    n: np.ndarray,
    t: np.ndarray,
    b: np.ndarray,
    m: np.ndarray,
    alpha_x: np.ndarray,
    alpha_y: np.ndarray,
) -> np.ndarray:
    """Anisotropic Beckmann (Ward 1992; RTR4 eqs. 9.37-9.38).

    D = exp(-((t.m/ax)^2 + (b.m/ay)^2)/(n.m)^2) / (pi ax ay (n.m)^4), 0 beyond the cut-off.
    """
    NoM = dot(n, m)
    ax, ay = _f64(alpha_x), _f64(alpha_y)
    x = dot(t, m) / ax
    y = dot(b, m) / ay
    c2 = NoM * NoM
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = (x * x + y * y) / c2
        D = np.exp(-e) / (np.pi * ax * ay * c2 * c2)
    return np.where((NoM > 0.0) & (e <= BECKMANN_EXPONENT_CUTOFF), D, 0.0)
