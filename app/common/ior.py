"""F0 <-> index of refraction (RTR4 §9.5): the conversions the scene's presets, the
material resolution and the Fresnel twins share."""

from __future__ import annotations

import numpy as np


def f0_from_ior(n2: np.ndarray, n1: np.ndarray | float = 1.0) -> np.ndarray:
    """RTR4 §9.5: F0 = ((n1 - n2)/(n1 + n2))^2 for an interface n1 -> n2."""
    n1 = np.asarray(n1, np.float64)
    n2 = np.asarray(n2, np.float64)
    return ((n1 - n2) / (n1 + n2)) ** 2


def ior_from_f0(f0: np.ndarray, n1: np.ndarray | float = 1.0) -> np.ndarray:
    """Inverse of ``f0_from_ior`` for a body in a medium n1: the root n2 > n1.

    n2 = n1 (1 + sqrt F0)/(1 - sqrt F0) (the other root, n1 (1 - sqrt F0)/(1 + sqrt F0),
    is the same F0 seen from inside: F0 does not tell the two sides apart).
    """
    s = np.sqrt(np.asarray(f0, np.float64))
    return np.asarray(n1, np.float64) * (1.0 + s) / (1.0 - s)


def f0_conductor(eta: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Normal-incidence reflectance of the index eta + i k: ((eta-1)^2 + k^2)/((eta+1)^2 + k^2)."""
    eta = np.asarray(eta, np.float64)
    k = np.asarray(k, np.float64)
    return ((eta - 1.0) ** 2 + k * k) / ((eta + 1.0) ** 2 + k * k)
