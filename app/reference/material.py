"""Twin of glsl/brdf/material.glsl: the metallic-roughness material and its BRDF."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.diffuse import Fd_lambert
from app.reference.specular import f_spec_GGX


@dataclass
class Surface:
    """Decoded G-buffer values; each field broadcasts (base_color has a last axis of 3)."""

    base_color: np.ndarray
    metallic: np.ndarray
    perceptual_roughness: np.ndarray
    f0_dielectric: np.ndarray


def material_F0(s: Surface) -> np.ndarray:
    """glTF 2.0 Appendix B; Burley 2012: F0 = mix(f0_dielectric, base_color, metallic)."""
    m = np.asarray(s.metallic, np.float64)[..., None]
    f0 = np.asarray(s.f0_dielectric, np.float64)[..., None]
    return f0 * (1.0 - m) + np.asarray(s.base_color, np.float64) * m


def material_rho_ss(s: Surface) -> np.ndarray:
    """rho_ss = (1 - metallic) base_color."""
    return (1.0 - np.asarray(s.metallic, np.float64))[..., None] * np.asarray(
        s.base_color, np.float64
    )


def material_alpha(s: Surface) -> np.ndarray:
    """alpha = r^2 (Burley 2012), r floored at MIN_PERCEPTUAL_ROUGHNESS."""
    r = np.maximum(np.asarray(s.perceptual_roughness, np.float64), MIN_PERCEPTUAL_ROUGHNESS)
    return r * r


def brdf_standard(s: Surface, n: np.ndarray, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """f(l, v) = rho_ss/pi + f_spec (Lambert + GGX microfacet specular), (..., 3)."""
    return Fd_lambert(material_rho_ss(s)) + f_spec_GGX(material_F0(s), material_alpha(s), n, l, v)
