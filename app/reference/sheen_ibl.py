"""Twin of the image-based part of glsl/brdf/sheen.glsl: the sheen layer under an
environment (RTR4 §9.10 with the split sum of RTR4 §10.5.2; docs/cloth.md, "Under an
environment").

glTF's sheen under an environment (the glTF Sample Viewer's) is a split sum of its own:
L = sheen_color E(n.v, r) L_charlie(d, r) + L_base (1 - max(sheen_color) E(n.v, r)), with E
the lobe's directional albedo (app/reference/sheen.py's table, the one the lights' albedo
scaling reads) and L_charlie the environment prefiltered by the Charlie lobe with n = v = d,
as the GGX split sum prefilters by GGX's: weight w(l) = D_charlie(h) (d.l)+, h the half
vector of d and l. That weight depends on l only through mu = d.l (h lies at theta_h with
cos(2 theta_h) = mu), so the prefilter is a convolution with a zonal kernel, which by the
Funk-Hecke theorem multiplies each SH band l of the environment by k_l = integral K P_l /
integral K. The lobe is broad (its facets lie near 45 degrees from d, l near 90 degrees),
so the environment's SH9 (already projected for the irradiance) carries it: no second set
of prefiltered cube maps. The bands have a closed form (``charlie_sh_bands``). The map is
read along n, not the mirror direction the Sample Viewer reads its Charlie map along:
measured closer to the lobe's integral (docs/cloth.md).

A module of its own because it needs both the sheen lobe (app/reference/sheen.py) and the
environment's SH9 (app/reference/ibl.py), and ibl.py's material import reaches sheen.py.
"""

from __future__ import annotations

import itertools

import numpy as np

from app.reference.constants import PI
from app.reference.environment import texel_directions
from app.reference.ibl import SH_C, map_texels
from app.reference.quadrature import gauss_legendre
from app.reference.sheen import _f64, load_table, sheen_alpha, sheen_E

# Panels of the kernel's quadrature over mu in [0, 1], graded toward 0 where the kernel
# peaks at mu ~ 2 alpha for small alpha, and toward 1 (a square-root branch at alpha = 1).
_KERNEL_PANELS = np.array(
    [0.0, 1e-4, 1e-3, 3e-3, 1e-2, 0.03, 0.1, 0.2, 0.4, 0.6, 0.8, 0.9, 0.99, 0.999, 1.0]
)  # fmt: skip


def charlie_prefilter_kernel(mu: np.ndarray, alpha: float) -> np.ndarray:
    """The Charlie prefilter's weight as a function of mu = R.l (up to a constant factor,
    which the normalised bands cancel): D_charlie(h) mu for mu > 0, with sin^2(theta_h) =
    (1 - mu)/2, so D ~ ((1 - mu)/2)^(1/(2 alpha)); the constant 2^(-1/(2 alpha)) is dropped
    (it underflows at the roughness floor): exp(ln(1 - mu) / (2 alpha)) mu."""
    mu = _f64(mu)
    one_minus = np.maximum(1.0 - mu, 1e-300)
    return np.where(mu > 0.0, np.exp(np.log(one_minus) / (2.0 * alpha)) * mu, 0.0)


def charlie_sh_bands_quadrature(sheen_roughness: float, nodes: int = 32) -> tuple[float, float]:
    """(k1, k2) = integral K P_l dmu / integral K dmu over mu in [0, 1] (P_1 = mu,
    P_2 = (3 mu^2 - 1)/2) by composite Gauss-Legendre on _KERNEL_PANELS: the check of
    ``charlie_sh_bands``' closed form."""
    alpha = float(sheen_alpha(sheen_roughness))
    k = np.zeros(3)
    for lo, hi in itertools.pairwise(_KERNEL_PANELS):
        mu, w = gauss_legendre(lo, hi, nodes)
        K = w * charlie_prefilter_kernel(mu, alpha)
        k += [np.sum(K), np.sum(K * mu), np.sum(K * (1.5 * mu * mu - 0.5))]
    return float(k[1] / k[0]), float(k[2] / k[0])


def charlie_sh_bands(sheen_roughness: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """(k1, k2), the factors the Charlie prefilter puts on the environment's SH bands 1 and 2
    (k0 = 1), in closed form: with p = 1/(2 alpha) the kernel is mu (1 - mu)^p, whose moments
    are Beta functions, integral mu^m (1 - mu)^p = m! / ((p + 1) ... (p + m + 1)); so
    k1 = 2 / (p + 3) and k2 = 9 / ((p + 3)(p + 4)) - 1/2 (derived here; the quadrature
    ``charlie_sh_bands_quadrature`` agrees to 1e-12, tests/test_sheen_ibl.py)."""
    p = 0.5 / sheen_alpha(sheen_roughness)
    return 2.0 / (p + 3.0), 9.0 / ((p + 3.0) * (p + 4.0)) - 0.5


def charlie_prefiltered_sh(L: np.ndarray, R: np.ndarray, sheen_roughness: float) -> np.ndarray:
    """L_charlie(R, r) from the environment's 9 SH coefficients L (9, 3) (app/reference/ibl.py
    sh9_project's order): sum_l k_l sum_m L_lm Y_lm(R), written as the irradiance formula's
    three band sums (Ramamoorthi & Hanrahan 2001, eq. 13, whose bands carry A_0 = pi,
    A_1 = 2 pi/3, A_2 = pi/4) reweighted by k_l / A_l, clamped at 0 (SH ringing), as the
    GLSL. R (..., 3) -> (..., 3)."""
    c1, c2, c3, c4, c5 = SH_C
    k1, k2 = charlie_sh_bands(sheen_roughness)
    x, y, z = (np.asarray(R, np.float64)[..., i, None] for i in range(3))
    band0 = c4 * L[0]
    band1 = 2.0 * c2 * (L[3] * x + L[1] * y + L[2] * z)
    band2 = (
        c1 * L[8] * (x * x - y * y) + c3 * L[6] * z * z - c5 * L[6]
        + 2.0 * c1 * (L[4] * x * y + L[7] * x * z + L[5] * y * z)
    )  # fmt: skip
    return np.maximum((band0 + 1.5 * k1 * band1 + 4.0 * k2 * band2) / PI, 0.0)


def charlie_prefiltered_exact(
    env: np.ndarray, rotation: float, R: np.ndarray, sheen_roughness: float
) -> np.ndarray:
    """L_charlie(R, r) by the exact sum over the map's texels (the reference the SH9 form is
    measured against): sum L K(R.l) dOmega / sum K(R.l) dOmega. R (..., 3) -> (..., 3)."""
    d, l_domega = map_texels(env, rotation)
    _, omega = texel_directions(*env.shape[:2])
    omega = omega.reshape(-1)
    alpha = float(sheen_alpha(sheen_roughness))
    flat = np.asarray(R, np.float64).reshape(-1, 3)
    out = np.empty_like(flat)
    for i, Ri in enumerate(flat):
        w = charlie_prefilter_kernel(d @ Ri, alpha)
        out[i] = (w[:, None] * l_domega).sum(0) / np.sum(w * omega)
    return out.reshape(np.shape(R))


def sheen_environment(
    sheen: str,
    sheen_color: np.ndarray,
    sheen_roughness: float,
    NoV: float,
    n: np.ndarray,
    L: np.ndarray,
    base: np.ndarray,
    table: np.ndarray | None = None,
) -> np.ndarray:
    """The sheen layer under image-based light (glsl/brdf/sheen.glsl sheen_environment),
    (3,): sheen_color E(n.v, r) L_charlie(n, r) + base (1 - max(sheen_color) E(n.v, r)), with
    ``base`` the environment light the base reflects (its split sum,
    app/reference/ibl.py split_sum_radiance), ``L`` the environment's SH9 (sh9_project,
    times its intensity), ``NoV`` clamped as the renderer clamps it. E is read at n.v alone:
    under a whole environment there is no single n.l for the lights' reciprocal max."""
    t = load_table() if table is None else table
    E = float(sheen_E(t, sheen, NoV, sheen_roughness))
    c = _f64(sheen_color)
    scale = float(np.clip(1.0 - np.max(c) * E, 0.0, 1.0))
    pre = charlie_prefiltered_sh(L, n, sheen_roughness)
    return c * E * pre + _f64(base) * scale
