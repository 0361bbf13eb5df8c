"""Scene lights -> the plain records both the GLSL and the float64 twin consume."""

from __future__ import annotations

import math

import numpy as np

from app.scene.model import Light

LIGHT_TYPE_CODE = {"directional": 0, "point": 1, "spot": 2}


def light_record(light: Light) -> dict:
    """One light as glsl/lights/punctual.glsl's PunctualLight, in float64."""
    direction = np.zeros(3) if light.direction is None else np.asarray(light.direction, float)
    if light.direction is not None:
        direction = direction / np.linalg.norm(direction)
    inner, outer = light.cone
    return {
        "type": LIGHT_TYPE_CODE[light.type],
        "position": np.zeros(3) if light.position is None else np.asarray(light.position, float),
        "direction": direction,
        "color": np.asarray(light.color, float) * light.intensity,
        # Directional lights ignore range; a finite stand-in keeps the texture finite.
        "range": 1.0 if light.type == "directional" else light.effective_range,
        "cos_outer": math.cos(math.radians(outer)),
        "cos_inner": math.cos(math.radians(inner)),
    }


def pack_lights(records: list[dict]) -> np.ndarray:
    """(N, 4, 4) float32 texels, the layout lighting.frag's fetch_light() reads.

    texel 0: position.xyz, type   texel 1: direction.xyz, range
    texel 2: c_light.rgb, cos_outer   texel 3: cos_inner, 0, 0, 0
    """
    out = np.zeros((max(len(records), 1), 4, 4), np.float32)
    for i, r in enumerate(records):
        out[i, 0] = (*r["position"], r["type"])
        out[i, 1] = (*r["direction"], r["range"])
        out[i, 2] = (*r["color"], r["cos_outer"])
        out[i, 3, 0] = r["cos_inner"]
    return out
