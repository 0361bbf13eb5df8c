"""Twin of glsl/brdf/fresnel.glsl: Fresnel reflectance terms."""

from __future__ import annotations

import numpy as np


def pow5_one_minus(x: np.ndarray) -> np.ndarray:
    """(1 - x)^5."""
    return (1.0 - np.asarray(x, np.float64)) ** 5


def F_schlick(F0: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """Schlick 1994; seed section 5: F = F0 + (1 - F0)(1 - (n.l)+)^5.

    ``F0`` (..., 3) or scalar, ``cos_theta`` (...); returns (..., 3).
    """
    F0 = np.asarray(F0, np.float64)
    c = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)[..., None]
    return F0 + (1.0 - F0) * pow5_one_minus(c)


def f0_from_ior(n2: np.ndarray, n1: np.ndarray | float = 1.0) -> np.ndarray:
    """Seed section 5: F0 = ((n1 - n2)/(n1 + n2))^2 for an interface n1 -> n2."""
    n1 = np.asarray(n1, np.float64)
    n2 = np.asarray(n2, np.float64)
    return ((n1 - n2) / (n1 + n2)) ** 2


def ior_from_f0(f0: np.ndarray) -> np.ndarray:
    """Inverse of ``f0_from_ior`` with n1 = 1 (n2 > 1): n = (1 + sqrt F0)/(1 - sqrt F0)."""
    s = np.sqrt(np.asarray(f0, np.float64))
    return (1.0 + s) / (1.0 - s)
