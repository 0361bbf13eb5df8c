"""Twin of glsl/brdf/diffuse.glsl: diffuse (subsurface) terms.

Each model returns the BRDF value f_diff (already divided by pi) with a last axis of 3.
As in the GLSL, the caller guarantees n.l > 0 and clamps n.v to [MIN_N_DOT_V, 1];
``Fd_oren_nayar`` takes vectors and clamps them itself. Evaluation order and the
cancellation-free factors follow the GLSL so that the two differ by float32 rounding only.
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot
from app.reference.constants import INV_PI, MIN_N_DOT_V
from app.reference.fresnel import pow5_one_minus


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def Fd_lambert(rho_ss: np.ndarray) -> np.ndarray:
    """Lambert 1760; RTR4 §9.3: f = rho_ss/pi, directional albedo rho_ss."""
    return np.asarray(rho_ss, np.float64) * INV_PI


def one_minus_pow5_one_minus(x: np.ndarray) -> np.ndarray:
    """1 - (1 - x)^5 as x (1 + m + m^2 + m^3 + m^4), m = 1 - x: no cancellation at small x."""
    x = _f64(x)
    m = 1.0 - x
    m2 = m * m
    return x * (1.0 + m + m2 + m2 * m + m2 * m2)


def Fd_shirley(rho_ss: np.ndarray, F0: np.ndarray, NoL: np.ndarray, NoV: np.ndarray) -> np.ndarray:
    """Shirley et al. 1997; RTR4 eq. 9.63: 21/(20 pi)(1 - F0) rho (1-(1-n.l)^5)(1-(1-n.v)^5).

    Smooth-surface diffuse coupled to the specular Fresnel; with F0 = 0 its directional
    albedo is exactly (1 - (1 - n.l)^5) rho_ss.
    """
    k = one_minus_pow5_one_minus(NoL) * one_minus_pow5_one_minus(NoV)
    return (21.0 / 20.0 * INV_PI) * k[..., None] * (1.0 - _f64(F0)) * _f64(rho_ss)


def Fd_ashikhmin_shirley(
    rho_ss: np.ndarray, F0: np.ndarray, NoL: np.ndarray, NoV: np.ndarray
) -> np.ndarray:
    """Ashikhmin & Shirley 2000: 28/(23 pi) rho (1 - F0)(1-(1-n.l/2)^5)(1-(1-n.v/2)^5).

    With F0 = 0 its directional albedo is exactly (1 - (1 - n.l/2)^5) rho_ss <= 31/32 rho_ss.
    """
    k = one_minus_pow5_one_minus(0.5 * _f64(NoL)) * one_minus_pow5_one_minus(0.5 * _f64(NoV))
    return (28.0 / 23.0 * INV_PI) * k[..., None] * (1.0 - _f64(F0)) * _f64(rho_ss)


def burley_retro(F_D90: np.ndarray, NoL: np.ndarray, NoV: np.ndarray) -> np.ndarray:
    """(1 + (F_D90 - 1)(1 - n.l)^5)(1 + (F_D90 - 1)(1 - n.v)^5), each factor (1 - p) + F_D90 p."""
    F_D90 = _f64(F_D90)
    light = one_minus_pow5_one_minus(NoL) + F_D90 * pow5_one_minus(NoL)
    view = one_minus_pow5_one_minus(NoV) + F_D90 * pow5_one_minus(NoV)
    return light * view


def Fd_burley(
    rho_ss: np.ndarray,
    perceptual_roughness: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    LoH: np.ndarray,
) -> np.ndarray:
    """Burley 2012, "Physically-Based Shading at Disney": rho/pi times the retro factor.

    F_D90 = 0.5 + 2 r (l.h)^2. Not energy conserving: albedo 1.55 at r = 1 near grazing.
    """
    LoH = _f64(LoH)
    F_D90 = 0.5 + 2.0 * _f64(perceptual_roughness) * LoH * LoH
    return _f64(rho_ss) * (INV_PI * burley_retro(F_D90, NoL, NoV))[..., None]


def Fd_burley_renormalized(
    rho_ss: np.ndarray,
    perceptual_roughness: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    LoH: np.ndarray,
) -> np.ndarray:
    """Lagarde & de Rousiers 2014 (Frostbite), Listing 1: Burley's model renormalised.

    energyBias = mix(0, 0.5, r), energyFactor = mix(1, 1/1.51, r),
    F_D90 = energyBias + 2 r (l.h)^2, times energyFactor.
    """
    r = _f64(perceptual_roughness)
    LoH = _f64(LoH)
    energy_bias = 0.5 * r
    energy_factor = 1.0 + (1.0 / 1.51 - 1.0) * r
    F_D90 = energy_bias + 2.0 * r * LoH * LoH
    return _f64(rho_ss) * (INV_PI * energy_factor * burley_retro(F_D90, NoL, NoV))[..., None]


# Oren-Nayar's sigma (rms facet slope angle) from the GGX alpha: sigma^2 = alpha^2 / 2.
SIGMA2_PER_ALPHA2 = 0.5


def oren_nayar_AB(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Oren & Nayar 1994's A and B for sigma = alpha/sqrt(2) (the GLSL computes them inline)."""
    s2 = SIGMA2_PER_ALPHA2 * _f64(alpha) ** 2
    return 1.0 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09)


def Fd_oren_nayar(
    rho_ss: np.ndarray, alpha: np.ndarray, n: np.ndarray, l: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """Oren & Nayar 1994, qualitative model, in vector form without trigonometry.

    f = rho/pi (A + B max(0, l.v - n.l n.v) / max(n.l, n.v)); see the GLSL for the
    derivation and for why sigma = alpha/sqrt(2).
    """
    NoL = np.clip(dot(n, l), 0.0, 1.0)
    NoV = np.clip(dot(n, v), MIN_N_DOT_V, 1.0)
    A, B = oren_nayar_AB(alpha)
    t = np.maximum(dot(l, v) - NoL * NoV, 0.0) / np.maximum(NoL, NoV)
    return _f64(rho_ss) * (INV_PI * (A + B * t))[..., None]


HAMMON_F_MULTI = 0.3641  # Hammon's 0.1159 times pi (RTR4 eq. 9.66)


def Fd_hammon(
    rho_ss: np.ndarray,
    F0: np.ndarray,
    alpha: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    NoH: np.ndarray,
    LoV: np.ndarray,
) -> np.ndarray:
    """Hammon 2017, GGX-based diffuse; RTR4 eqs. 9.64-9.66.

    f = rho/pi ((1 - alpha) f_smooth + alpha f_rough + rho f_multi) with
    f_smooth = 21/20 (1 - F0)(1-(1-n.l)^5)(1-(1-n.v)^5),
    f_rough = k (0.9 - 0.4 k)(0.5 + n.h)/n.h, k = 0.5 + 0.5 l.v, f_multi = 0.3641 alpha.
    n.h is floored at MIN_N_DOT_V/2 as in the GLSL: a no-op while v is above the horizon,
    it keeps v below it (n.v < -n.l, where h gave n.h = 0) from dividing by 0.
    """
    rho_ss = _f64(rho_ss)
    alpha = _f64(alpha)
    NoH = np.maximum(_f64(NoH), 0.5 * MIN_N_DOT_V)
    smooth = one_minus_pow5_one_minus(NoL) * one_minus_pow5_one_minus(NoV)
    f_smooth = (21.0 / 20.0) * (1.0 - _f64(F0)) * smooth[..., None]
    k_facing = 0.5 + 0.5 * _f64(LoV)
    f_rough = k_facing * (0.9 - 0.4 * k_facing) * ((0.5 + NoH) / NoH)
    f_multi = HAMMON_F_MULTI * alpha
    a = alpha[..., None]
    mixed = (1.0 - a) * f_smooth + a * f_rough[..., None] + rho_ss * f_multi[..., None]
    return rho_ss * INV_PI * mixed
