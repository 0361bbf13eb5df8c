"""Scene lights -> the plain records both the GLSL and the float64 twin consume."""

from __future__ import annotations

import math

import numpy as np

from app.scene.model import Environment, Light

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


def fibonacci_sphere(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over the sphere (a spherical Fibonacci lattice,
    Gonzalez 2010): equal-area cells, so each stands for 4 pi / count steradians."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))  # the golden angle
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def environment_records(env: Environment | None) -> list[dict]:
    """A uniform environment as directional lights that integrate it.

    L_o = integral f L (n.l)+ dl ~ sum_i f L (n.l_i)+ 4 pi / N over N equal-area directions;
    the illumination sum gives pi sum_i f c_light (n.l_i)+, so c_light = 4 L / N.
    """
    if env is None:
        return []
    color = np.asarray(env.radiance, float) * (4.0 / env.samples)
    return [
        {
            "type": LIGHT_TYPE_CODE["directional"],
            "position": np.zeros(3),
            "direction": -d,  # light travels from direction d towards the surface
            "color": color,
            "range": 1.0,
            "cos_outer": 0.0,
            "cos_inner": 1.0,
        }
        for d in fibonacci_sphere(env.samples)
    ]


def pack_lights(records: list[dict]) -> np.ndarray:
    """(N, 3, 4) float32 texels, the layout glsl/lights/punctual.glsl's fetch_light() reads.

    texel 0: position.xyz, cos_inner   texel 1: direction.xyz, range
    texel 2: c_light.rgb, cos_outer
    The type is implied, so a light is three fetches, not four (8 % off the culled
    256-light frame, 13 % off the unculled one; docs/performance.md): range < 0 marks a
    directional light, cos_outer < -1 a point light (no cone).
    """
    out = np.zeros((max(len(records), 1), 3, 4), np.float32)
    for i, r in enumerate(records):
        light_range = -1.0 if r["type"] == LIGHT_TYPE_CODE["directional"] else r["range"]
        cos_outer = -2.0 if r["type"] == LIGHT_TYPE_CODE["point"] else r["cos_outer"]
        out[i, 0] = (*r["position"], r["cos_inner"])
        out[i, 1] = (*r["direction"], light_range)
        out[i, 2] = (*r["color"], cos_outer)
    return out
