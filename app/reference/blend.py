"""Twin of glsl/material/blend.glsl: blending materials by their parameters (RTR4 §9.13).

The offline bake (app/textures/bake.py) runs these on textures; the G-buffer pass runs
the GLSL per pixel. Both mix BRDF inputs, never shaded colours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Layer:
    """The material parameters one layer contributes, arrays broadcasting over texels."""

    base_color: np.ndarray  # (..., 3) linear
    metallic: np.ndarray  # (...)
    perceptual_roughness: np.ndarray  # (...) r; alpha = r^2
    f0: np.ndarray  # (...)
    anisotropy: np.ndarray  # (...)
    normal: np.ndarray  # (..., 3) unit, tangent space


def blend_weight(mask: np.ndarray, threshold: float, softness: float) -> np.ndarray:
    """Weight of the top layer: a smoothstep ramp ``softness`` wide centred on
    ``threshold``; a hard step at softness = 0."""
    mask = np.asarray(mask, np.float64)
    if softness <= 0.0:
        return (mask >= threshold).astype(np.float64)
    x = np.clip((mask - (threshold - 0.5 * softness)) / softness, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def blend_layers(a: Layer, b: Layer, w: np.ndarray) -> Layer:
    """RTR4 §9.13: linear mixes of the parameters (roughness in perceptual r), normals
    mixed as vectors and renormalised (both have z > 0, so the mix never vanishes)."""
    w = np.asarray(w, np.float64)
    w3 = w[..., None]

    def mix(x: np.ndarray, y: np.ndarray, t: np.ndarray) -> np.ndarray:
        return np.asarray(x, np.float64) * (1.0 - t) + np.asarray(y, np.float64) * t

    n = mix(a.normal, b.normal, w3)
    return Layer(
        mix(a.base_color, b.base_color, w3),
        mix(a.metallic, b.metallic, w),
        mix(a.perceptual_roughness, b.perceptual_roughness, w),
        mix(a.f0, b.f0, w),
        mix(a.anisotropy, b.anisotropy, w),
        n / np.linalg.norm(n, axis=-1, keepdims=True),
    )
