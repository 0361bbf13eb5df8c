"""Twin of glsl/brdf/specular.glsl: the specular microfacet BRDF."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from app.common.models import Model
from app.reference import masking, ndf
from app.reference._vec import dot, normalize
from app.reference.constants import MIN_N_DOT_V
from app.reference.fresnel import F_schlick
from app.reference.masking import V_height_correlated_GGX
from app.reference.ndf import D_GGX


def f_spec_GGX(
    F0: np.ndarray, alpha: np.ndarray, n: np.ndarray, l: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """Cook & Torrance 1982; RTR4 §9.8: F(h,l) G2 D(h) / (4 |n.l| |n.v|).

    GGX D, height-correlated Smith G2 (as V = G2/(4|n.l||n.v|)), Schlick F; returns (..., 3).
    """
    h = normalize(np.asarray(l, np.float64) + np.asarray(v, np.float64))
    NoL = np.clip(dot(n, l), 0.0, 1.0)
    NoV = np.clip(dot(n, v), MIN_N_DOT_V, 1.0)
    D = D_GGX(n, h, alpha)
    V = V_height_correlated_GGX(NoL, NoV, alpha)
    F = F_schlick(F0, dot(l, h))
    return F * (D * V)[..., None]


def D_selected(
    model: Model, n: ArrayLike, h: ArrayLike, alpha: ArrayLike, gtr_gamma: float
) -> np.ndarray:
    """D(h) of the model's isotropic NDF."""
    match model.ndf:
        case "beckmann":
            return ndf.D_beckmann(n, h, alpha)
        case "blinn_phong":
            return ndf.D_blinn_phong(n, h, alpha)
        case "gtr":
            return ndf.D_GTR(n, h, alpha, gtr_gamma)
    return ndf.D_GGX(n, h, alpha)


def D_selected_aniso(
    model: Model,
    n: ArrayLike,
    t: ArrayLike,
    b: ArrayLike,
    h: ArrayLike,
    alpha_x: ArrayLike,
    alpha_y: ArrayLike,
) -> np.ndarray:
    """D(h) of the model's anisotropic NDF (GGX or Beckmann), alpha_x along t."""
    if model.ndf == "beckmann":
        return ndf.D_beckmann_aniso(n, t, b, h, alpha_x, alpha_y)
    return ndf.D_GGX_aniso(n, t, b, h, alpha_x, alpha_y)


def Lambda_selected(model: Model, c: ArrayLike, alpha: ArrayLike, gtr_gamma: float) -> np.ndarray:
    """Smith Lambda of the model's NDF at cosine c, roughness alpha along the azimuth."""
    match model.ndf:
        case "beckmann" if model.lambda_form == "rational":
            return masking.Lambda_beckmann_rational(c, alpha)
        case "beckmann":
            return masking.Lambda_beckmann(c, alpha)
        case "blinn_phong":
            return masking.Lambda_blinn_phong(c, alpha)
        case "gtr":
            return masking.Lambda_GTR(c, alpha, gtr_gamma)
    return masking.Lambda_GGX(c, alpha)


def G2_selected(
    model: Model, Lambda_v: ArrayLike, Lambda_l: ArrayLike, n: ArrayLike, l: ArrayLike, v: ArrayLike
) -> np.ndarray:
    """The model's joint masking-shadowing G2 from the two Lambdas."""
    if model.g2 == "separable":
        return masking.G2_separable(Lambda_v, Lambda_l)
    if model.g2 in ("direction_correlated", "height_direction_correlated"):
        phi = masking.azimuth_difference(n, l, v)
        lam = (
            masking.lambda_phi_rational(phi)
            if model.correlation == "rational"
            else masking.lambda_phi_exp(phi)
        )
        if model.g2 == "direction_correlated":
            return masking.G2_direction_correlated(Lambda_v, Lambda_l, lam)
        return masking.G2_height_direction_correlated(Lambda_v, Lambda_l, lam)
    return masking.G2_height_correlated(Lambda_v, Lambda_l)
