"""Twin of glsl/lights/punctual.glsl: punctual lights."""

from __future__ import annotations

import numpy as np

from app.common.lights import LightType, PunctualLight
from app.reference._vec import dot

LIGHT_MIN_DISTANCE = 0.01


def window_falloff(dist2: np.ndarray, light_range: float) -> np.ndarray:
    """Karis 2013; RTR4 eq. 5.14: ((1 - (r/r_max)^4)+)^2."""
    x = np.asarray(dist2, np.float64) / (light_range * light_range)
    t = np.clip(1.0 - x * x, 0.0, 1.0)
    return t * t


def spot_cone(cos_theta: np.ndarray, cos_outer: float, cos_inner: float) -> np.ndarray:
    """RTR4 eq. 5.18-5.19: t = clamp((cos - cos_outer)/(cos_inner - cos_outer)), t^2."""
    t = np.clip((cos_theta - cos_outer) / max(cos_inner - cos_outer, 1e-4), 0.0, 1.0)
    return t * t


def light_at(light: PunctualLight, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """c_light arriving at points ``p`` (..., 3) and the unit directions towards the light."""
    p = np.asarray(p, np.float64)
    color = np.asarray(light.color, np.float64)
    if light.type == LightType.DIRECTIONAL:
        l = np.broadcast_to(-np.asarray(light.direction, np.float64), p.shape)
        return np.broadcast_to(color, p.shape), l
    d = np.asarray(light.position, np.float64) - p
    dist2 = dot(d, d)
    l = d / np.sqrt(np.maximum(dist2, 1e-20))[..., None]
    atten = window_falloff(dist2, light.range) / np.maximum(dist2, LIGHT_MIN_DISTANCE**2)
    if light.type == LightType.SPOT:
        atten = atten * spot_cone(
            dot(-l, np.asarray(light.direction, np.float64)),
            light.cos_outer,
            light.cos_inner,
        )
    return color * atten[..., None], l
