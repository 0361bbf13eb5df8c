"""Twin of glsl/brdf/fresnel.glsl: Fresnel reflectance terms.

Besides the twins of the GLSL functions this module measures Schlick's approximation
against the exact Fresnel equations (``fresnel_schlick_max_error``), which
scripts/fresnel_tables.py turns into the generated tables of docs/fresnel.md.
"""

from __future__ import annotations

import numpy as np

from app.common.ior import f0_conductor, f0_from_ior


def pow5_one_minus(x: np.ndarray) -> np.ndarray:
    """(1 - x)^5."""
    return (1.0 - np.asarray(x, np.float64)) ** 5


def F_schlick(F0: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """Schlick 1994; RTR4 §9.5: F = F0 + (1 - F0)(1 - (n.l)+)^5.

    ``F0`` (..., 3) or scalar, ``cos_theta`` (...); returns (..., 3).
    """
    F0 = np.asarray(F0, np.float64)
    c = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)[..., None]
    return F0 + (1.0 - F0) * pow5_one_minus(c)


def F_schlick_generalized(
    F0: np.ndarray, F90: np.ndarray, exponent: np.ndarray, cos_theta: np.ndarray
) -> np.ndarray:
    """RTR4 §9.5 (RTR4 sec. 9.5): F = F0 + (F90 - F0)(1 - (n.l)+)^(1/p).

    ``exponent`` = 1/p > 0 (5 gives Schlick); 0^exponent is 0, as the GLSL writes it out.
    ``F0``, ``F90`` (..., 3); ``exponent``, ``cos_theta`` (...); returns (..., 3).
    """
    F0 = np.asarray(F0, np.float64)
    F90 = np.asarray(F90, np.float64)
    m = 1.0 - np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    e = np.asarray(exponent, np.float64)
    with np.errstate(divide="ignore"):
        w = np.where(m > 0.0, np.power(np.where(m > 0.0, m, 1.0), e), 0.0)
    return F0 + (F90 - F0) * w[..., None]


def F_dielectric(eta: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """Fresnel 1823; Born & Wolf sec. 1.5.2: unpolarised reflectance of a dielectric interface.

    ``eta`` = n2/n1 (far side over incident side; < 1 is internal reflection, exactly 1
    past the critical angle). Evaluated as the GLSL does: with d = (eta - 1)(eta + 1) and
    g = sqrt(d + c^2), r_s = -d/(g + c)^2 and r_p = d((eta^2 + 1)c^2 - 1)/(eta^2 c + g)^2,
    free of the cancellation in c - g; eta = 1 gives exactly 0. Returns (...).
    """
    eta = np.asarray(eta, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)
    d = (eta - 1.0) * (eta + 1.0)
    g2 = d + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    e2 = eta * eta
    gc = g + c
    q = e2 * c + g
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = d / (gc * gc)
        rp = d * ((e2 + 1.0) * c * c - 1.0) / (q * q)
    F = 0.5 * (rs * rs + rp * rp)
    return np.where(d == 0.0, 0.0, np.where(g2 <= 0.0, 1.0, F))


def F_conductor(eta: np.ndarray, k: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """Born & Wolf ch. 14; Lagarde 2013: unpolarised reflectance for the index eta + i k.

    ``eta``, ``k`` (..., 3) relative to the incident medium, ``cos_theta_i`` (...); returns
    (..., 3). The same cancellation-free products as the GLSL (see the comment there):
    R_s = |eta_c^2 - 1|^2 / |c + w|^4 and R_p = R_s |eta_c^2 c^2 - s^2|^2 / |w c + s^2|^4,
    w = a + i b = sqrt(eta_c^2 - s^2) with a, b from the non-cancelling root and a b = eta k.
    """
    eta = np.asarray(eta, np.float64)
    k = np.asarray(k, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)[..., None]
    c2 = c * c
    s2 = 1.0 - c2
    d = (eta - 1.0) * (eta + 1.0) - k * k
    p = 2.0 * eta * k
    t = d + c2
    m = np.sqrt(t * t + p * p)
    big = np.sqrt(0.5 * (m + np.abs(t)))
    small = 0.5 * p / np.maximum(big, 1e-30)
    a = np.where(t < 0.0, small, big)
    b = np.where(t < 0.0, big, small)
    ac = a + c
    D = ac * ac + b * b
    N = d * d + p * p
    Rs = N / np.maximum(D * D, 1e-30)
    acs = a * c + s2
    bc = b * c
    E = acs * acs + bc * bc
    re = (d + 1.0) * c2 - s2
    im = p * c2
    M = re * re + im * im
    Rp = Rs * M / np.maximum(E * E, 1e-30)
    return 0.5 * (Rs + Rp)


def cos_theta_schlick(eta: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """RTR4 sec. 9.5.2: the cosine for Schlick's approximation.

    cos_i for external reflection (eta >= 1); for internal reflection the transmitted
    cos_t = sqrt(1 - (1 - c^2)/eta^2) = sqrt((eta - 1)(eta + 1) + c^2)/eta, and 0 past the
    critical angle (F_schlick then gives exactly 1). Returns (...).
    """
    eta = np.asarray(eta, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)
    g2 = (eta - 1.0) * (eta + 1.0) + c * c
    cos_t = np.minimum(np.sqrt(np.maximum(g2, 0.0)) / eta, 1.0)
    return np.where(eta >= 1.0, c, np.where(g2 > 0.0, cos_t, 0.0))


# --- Index <-> F0 (twin-only helpers) ---------------------------------------------------------


def critical_cos(eta: np.ndarray) -> np.ndarray:
    """cos(theta_c) = sqrt(1 - eta^2) for internal reflection (eta < 1); 0 for eta >= 1."""
    eta = np.asarray(eta, np.float64)
    return np.sqrt(np.maximum((1.0 - eta) * (1.0 + eta), 0.0))


# --- Schlick against the exact equations -------------------------------------------------------

# The angle grid for the largest-error search: 0.001 degree steps, plus the critical angle
# itself where there is one (where the exact internal reflectance has its kink).
ANGLES_DEG = np.linspace(0.0, 90.0, 90001)


def fresnel_schlick_max_error(
    eta: np.ndarray,
    k: np.ndarray | None = None,
    angles_deg: np.ndarray = ANGLES_DEG,
    *,
    transmitted_cos: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest |Schlick - exact| over the angle of incidence, per channel.

    ``eta`` (and ``k`` for a conductor) is the relative index, shape (C,). Schlick is given
    the exact F0 of that index (so only the shape of the curve is compared, not the choice
    of F0) and, for a dielectric, the cosine of ``cos_theta_schlick`` (the transmitted one
    for internal reflection), or the incident cosine if ``transmitted_cos`` is False (the
    naive use, to show what the transmitted cosine buys). Returns (max error (C,), angle
    of the maximum in degrees (C,), signed error there (C,)).
    """
    eta = np.atleast_1d(np.asarray(eta, np.float64))
    theta = np.asarray(angles_deg, np.float64)
    extra = np.degrees(np.arcsin(eta[eta < 1.0]))
    theta = np.unique(np.concatenate([theta, extra]))
    cos_i = np.cos(np.radians(theta))
    if k is None:
        exact = F_dielectric(eta[None, :], cos_i[:, None])
        F0 = f0_from_ior(eta)
        cos_s = (
            cos_theta_schlick(eta[None, :], cos_i[:, None]) if transmitted_cos else cos_i[:, None]
        )
        approx = F0 + (1.0 - F0) * pow5_one_minus(cos_s)
    else:
        k = np.atleast_1d(np.asarray(k, np.float64))
        exact = F_conductor(eta, k, cos_i)
        approx = F_schlick(f0_conductor(eta, k), cos_i)
    err = approx - exact
    i = np.argmax(np.abs(err), axis=0)
    cols = np.arange(len(eta))
    return np.abs(err[i, cols]), theta[i], err[i, cols]
