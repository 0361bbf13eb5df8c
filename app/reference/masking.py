"""Twin of glsl/brdf/masking.glsl: Smith Lambda, G1 and the joint G2."""

from __future__ import annotations

import numpy as np


def Lambda_GGX(cos_theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Heitz 2014 eq. 72: Lambda = (sqrt(1 + alpha^2 tan^2 theta) - 1)/2."""
    c = np.asarray(cos_theta, np.float64)
    a = np.asarray(alpha, np.float64)
    c2 = c * c
    return 0.5 * (np.sqrt(c2 + a * a * (1.0 - c2)) / c - 1.0)


def G1_smith(Lambda_v: np.ndarray) -> np.ndarray:
    """Smith 1967; seed section 7: G1 = 1/(1 + Lambda(v)) (for m.v > 0)."""
    return 1.0 / (1.0 + np.asarray(Lambda_v, np.float64))


def G2_height_correlated_GGX(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Heitz 2014 eq. 99; seed section 7: G2 = 1/(1 + Lambda(v) + Lambda(l))."""
    return 1.0 / (1.0 + Lambda_GGX(NoL, alpha) + Lambda_GGX(NoV, alpha))


def V_height_correlated_GGX(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """G2/(4 |n.l| |n.v|) for the height-correlated GGX G2, in the division-free form."""
    NoL = np.asarray(NoL, np.float64)
    NoV = np.asarray(NoV, np.float64)
    a2 = np.asarray(alpha, np.float64) ** 2
    lambda_v = NoL * np.sqrt(NoV * NoV * (1.0 - a2) + a2)
    lambda_l = NoV * np.sqrt(NoL * NoL * (1.0 - a2) + a2)
    return 0.5 / (lambda_v + lambda_l)
