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


# --- the coat-base inter-reflection series ("weidlich_wilkie_series") ----------------------
# Least-squares fit of the GGX single-scattering average albedo's loss 1 - E_avg(r) (the
# height-correlated table of app/reference/multiscatter.py) on r in [0, 1]:
# r^2 (a + b r + c r^2), within 2.2e-3 of the table; the series needs it without a table.
E_AVG_LOSS_FIT = (-0.258, 2.087, -1.240)


def E_avg_ggx_fit(perceptual_roughness: np.ndarray | float) -> np.ndarray:
    """E_avg(r) of the GGX specular with F = 1 (Kulla & Conty 2017's average albedo), by the
    fit E_AVG_LOSS_FIT, in [0, 1]."""
    r = np.clip(_f64(perceptual_roughness), 0.0, 1.0)
    a, b, c = E_AVG_LOSS_FIT
    return 1.0 - np.maximum(r * r * (a + r * (b + r * c)), 0.0)


def clearcoat_internal_reflectance(
    c: np.ndarray | float, F0c: np.ndarray | float, eta_c: np.ndarray | float
) -> np.ndarray:
    """r_i: the fraction of diffuse (cosine-distributed) light inside the coat that its top
    reflects back down, 1 - (1 - c F_avg)/eta_c^2, F_avg = F0 + (1 - F0)/21 Schlick's
    hemispherical average (the crossings' own F). What escapes, (1 - c F_avg)/eta_c^2, is
    what a Lambertian base's lobe through the coat, f_base(l_t, v_t)/eta_c^2 with the
    crossing 1 - c F(n.v), integrates to (Stokes/reciprocity: the n^2 law)."""
    c, F0c, eta_c = _f64(c), _f64(F0c), _f64(eta_c)
    F_avg = F0c + (1.0 - F0c) / 21.0
    return 1.0 - (1.0 - c * F_avg) / (eta_c * eta_c)


def clearcoat_lobe_trapping(
    c: np.ndarray | float,
    F0c: np.ndarray | float,
    eta_c: np.ndarray | float,
    r_i: np.ndarray,
    alpha: np.ndarray | float,
) -> np.ndarray:
    """r_s: the fraction of a GGX base lobe of width alpha that the coat's top reflects
    back down on its first return. A smooth lobe leaves near its mirror direction, where
    the coat reflects its normal-incidence c F0; a rough one spreads past the critical angle
    like diffuse light (r_i). The weight s is the lobe's share beyond the critical angle at
    normal incidence: GGX's cosine-weighted half-vector CDF (Walter et al. 2007),
    P(theta_h > theta_c/2) = alpha^2 / (alpha^2 + tan^2(theta_c/2)),
    tan^2(theta_c/2) = (1 - cos theta_c)/(1 + cos theta_c), cos theta_c = sqrt(1 - 1/eta_c^2)."""
    eta_c, alpha = _f64(eta_c), _f64(alpha)
    cos_c = np.sqrt(np.maximum(1.0 - 1.0 / (eta_c * eta_c), 0.0))
    tan2 = (1.0 - cos_c) / (1.0 + cos_c)
    a2 = alpha * alpha
    s = a2 / (a2 + tan2)
    return (1.0 - s) * (_f64(c) * _f64(F0c)) + s * r_i
