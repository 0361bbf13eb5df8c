"""Twin of glsl/brdf/specular.glsl: the specular microfacet BRDF."""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot, normalize
from app.reference.constants import MIN_N_DOT_V
from app.reference.fresnel import F_schlick
from app.reference.masking import V_height_correlated_GGX
from app.reference.ndf import D_GGX


def f_spec_GGX(
    F0: np.ndarray, alpha: np.ndarray, n: np.ndarray, l: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """Cook & Torrance 1982; seed section 8: F(h,l) G2 D(h) / (4 |n.l| |n.v|).

    GGX D, height-correlated Smith G2 (as V = G2/(4|n.l||n.v|)), Schlick F; returns (..., 3).
    """
    h = normalize(np.asarray(l, np.float64) + np.asarray(v, np.float64))
    NoL = np.clip(dot(n, l), 0.0, 1.0)
    NoV = np.clip(dot(n, v), MIN_N_DOT_V, 1.0)
    D = D_GGX(n, h, alpha)
    V = V_height_correlated_GGX(NoL, NoV, alpha)
    F = F_schlick(F0, dot(l, h))
    return F * (D * V)[..., None]
