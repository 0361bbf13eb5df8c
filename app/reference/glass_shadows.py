"""Float64 twin of the glass shadows' transmittance (glsl/passes/shadow_glass.frag;
docs/shadows.md, "Glass"). The lighting pass's lookup of it (glsl/lights/shadows.glsl) is
twinned by ``glass_transmittance_at`` in app/reference/shadows.py.

A transmissive body between a light and a receiver lets through, per channel,

    T = transmission (1 - metallic) (1 - F0) base_color exp(-sigma d),
    sigma = -ln(attenuation_color) / attenuation_distance,

the transmission pass's weight at normal incidence (one interface, Schlick's F at n.v = 1
is F0) and Beer-Lambert over the volume's thickness d (KHR_materials_volume), once per
body. Where the glass has a base colour, transmission or thickness map, the three are the
material's constants times the texels at the shadow map texel's UV (the transmission pass's
factors; glsl/passes/shadow_glass.frag GLASS_MAPS): ``glass_transmittance`` takes them as
they are. Several bodies along the light's straight line multiply; a receiver in front of the
nearest glass (the glass's own lit face) is not tinted. No caustics: the light refracted
by the glass is not redirected, only attenuated along the straight line.
"""

from __future__ import annotations

import numpy as np

from app.reference.transmission import beer_lambert


def glass_transmittance(
    base_color: np.ndarray,
    transmission: float,
    metallic: float,
    f0: float,
    thickness: float,
    attenuation_color: np.ndarray,
    attenuation_distance: float,
) -> np.ndarray:
    """(3,) the share of the light, per channel, that one glass body lets through along a
    straight line: ``thickness`` in metres (the object's times its scale; 0 thin-walled)."""
    weight = float(transmission) * (1.0 - float(metallic)) * (1.0 - float(f0))
    base = np.asarray(base_color, np.float64)
    return weight * base * beer_lambert(attenuation_color, attenuation_distance, thickness)


def transmittance_product(
    layers: list[tuple[float, np.ndarray]], receiver_depth: float
) -> np.ndarray:
    """(3,) the light's transmittance at a receiver of window depth ``receiver_depth``
    along one texel of a map: the product of the glass ``layers`` (window depth, (3,)
    transmittance) when the receiver lies behind the nearest of them, else 1 (what the
    glass target holds: the product in rgb, the nearest depth in alpha)."""
    if not layers:
        return np.ones(3)
    nearest = min(depth for depth, _ in layers)
    if receiver_depth <= nearest:
        return np.ones(3)
    out = np.ones(3)
    for _, t in layers:
        out = out * np.asarray(t, np.float64)
    return out
