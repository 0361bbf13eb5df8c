"""Twin of glsl/brdf/clearcoat.glsl: the terms of a clear coat, a transparent absorbing
layer of relative index ``eta`` over any base BRDF (RTR4 §9.12). Same names, same order
of operations, float64, broadcasting; app/reference/material.py composes them with the
base (``clearcoat_factors``), as glsl/brdf/material.glsl does.
"""

from __future__ import annotations

import numpy as np

from app.reference.fresnel import pow5_one_minus
from app.reference.masking import V_height_correlated_GGX
from app.reference.ndf import D_GGX


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def clearcoat_F0(eta: np.ndarray | float) -> np.ndarray:
    """RTR4 eq. 9.17: F0 = ((eta - 1)/(eta + 1))^2 of the coat's outer interface."""
    eta = _f64(eta)
    r = (eta - 1.0) / (eta + 1.0)
    return r * r


def F_clearcoat_schlick(F0c: np.ndarray | float, cos_theta: np.ndarray) -> np.ndarray:
    """Schlick 1994 (RTR4 §9.5) with the coat's scalar F0; scalar per point."""
    F0c = _f64(F0c)
    return F0c + (1.0 - F0c) * pow5_one_minus(np.clip(_f64(cos_theta), 0.0, 1.0))


def clearcoat_cos_refracted(eta: np.ndarray | float, mu: np.ndarray) -> np.ndarray:
    """Snell's law, RTR4 eq. 9.31: cos_t = sqrt((eta - 1)(eta + 1) + mu^2)/eta inside the coat."""
    eta, mu = _f64(eta), _f64(mu)
    d = (eta - 1.0) * (eta + 1.0)
    return np.sqrt(np.maximum(d + mu * mu, 0.0)) / eta


def f_clearcoat_ggx(
    alpha_c: np.ndarray | float,
    F0c: np.ndarray | float,
    n: np.ndarray,
    h: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    LoH: np.ndarray,
) -> np.ndarray:
    """The coat's own reflection (Filament; glTF KHR_materials_clearcoat), RTR4 eq. 9.34:
    F_schlick(F0c, l.h) D_GGX(h) V_height_correlated_GGX, with the coat's alpha."""
    return F_clearcoat_schlick(F0c, LoH) * (
        D_GGX(n, h, alpha_c) * V_height_correlated_GGX(NoL, NoV, alpha_c)
    )


def T_clearcoat_schlick(
    c: np.ndarray | float, F0c: np.ndarray | float, mu: np.ndarray
) -> np.ndarray:
    """One crossing: 1 - c F(mu) = (1 - c) + c (1 - F0) (1 - (1 - mu)^5), the last factor as
    the polynomial x (5 - 10x + 10x^2 - 5x^3 + x^4) (precise at grazing mu)."""
    c, F0c = _f64(c), _f64(F0c)
    x = np.clip(_f64(mu), 0.0, 1.0)
    q = x * (5.0 + x * (-10.0 + x * (10.0 + x * (-5.0 + x))))
    return (1.0 - c) + c * ((1.0 - F0c) * q)


def T_clearcoat_filament(
    c: np.ndarray | float, F0c: np.ndarray | float, NoL: np.ndarray, NoV: np.ndarray
) -> np.ndarray:
    """Filament's attenuation of the base, on the way in and out (reciprocal):
    T = (1 - c F(n.l)) (1 - c F(n.v))."""
    return T_clearcoat_schlick(c, F0c, NoL) * T_clearcoat_schlick(c, F0c, NoV)


def A_clearcoat_beer_lambert(
    T0: np.ndarray, eta: np.ndarray | float, NoL: np.ndarray, NoV: np.ndarray
) -> np.ndarray:
    """Beer-Lambert (RTR4 §14.1.2) along the refracted path down and up:
    A = T0^(1/cos_t(n.l) + 1/cos_t(n.v)), T0 the transmittance at normal incidence once;
    (..., 3)."""
    e = 1.0 / clearcoat_cos_refracted(eta, NoL) + 1.0 / clearcoat_cos_refracted(eta, NoV)
    T0 = _f64(T0)
    with np.errstate(divide="ignore"):
        lg = np.log2(np.maximum(T0, 1e-30))
    return np.where(T0 > 0.0, np.exp2(_f64(e)[..., None] * lg), 0.0)


def f0_under_clearcoat(f0: np.ndarray | float, eta: np.ndarray | float) -> np.ndarray:
    """The F0 of a dielectric base against the coat rather than the medium, from its F0 in
    the medium (s = sqrt(F0), n = (1 + s)/(1 - s), RTR4 eq. 9.18):
    F0' = (((1 + s) - eta (1 - s)) / ((1 + s) + eta (1 - s)))^2."""
    s = np.sqrt(np.clip(_f64(f0), 0.0, 1.0))
    a = 1.0 + s
    b = _f64(eta) * (1.0 - s)
    r = (a - b) / (a + b)
    return r * r


def clearcoat_refract_in(eta: np.ndarray | float, n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Snell's law (RTR4 eq. 9.31) for a unit direction d outside, pointing away from the
    surface: the same direction inside the coat, d_t = (d - (n.d) n)/eta + cos_t n, unit for
    any n.d (cos_t from (n.d)^2), so a direction slightly below the horizon lands above it."""
    eta, n, d = _f64(eta), _f64(n), _f64(d)
    mu = np.sum(n * d, -1)
    cos_t = clearcoat_cos_refracted(eta, mu)
    eta_ = eta[..., None] if eta.ndim else eta
    return (d - mu[..., None] * n) / eta_ + cos_t[..., None] * n


def clearcoat_solid_angle_compression(eta: np.ndarray | float) -> np.ndarray:
    """What refraction does to radiance, crossing in and back out (RTR4 §9.12's coat; the
    n^2 law of radiance, Veach 1997 §5.2): a BRDF evaluated with the refracted directions
    is worth 1/eta^2 of itself outside, since cos_t d omega_t = cos d omega / eta^2."""
    eta = _f64(eta)
    return 1.0 / (eta * eta)
