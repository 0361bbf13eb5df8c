"""Twin of glsl/brdf/ndf.glsl: normal distribution functions."""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot


def D_GGX(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Walter et al. 2007 (GGX); Trowbridge & Reitz 1975; seed section 8.

    D(m) = chi+(n.m) alpha^2 / (pi (1 + (n.m)^2 (alpha^2 - 1))^2), with the denominator
    written as (n.m)^2 alpha^2 + |n x m|^2 exactly as the GLSL does.
    """
    NoM = dot(n, m)
    nxm = np.cross(np.asarray(n, np.float64), np.asarray(m, np.float64))
    a2 = np.asarray(alpha, np.float64) ** 2
    d = NoM * NoM * a2 + dot(nxm, nxm)
    with np.errstate(divide="ignore", invalid="ignore"):
        D = a2 / (np.pi * d * d)
    return np.where(NoM > 0.0, D, 0.0)
