"""Punctual lights as the GLSL and the float64 twin consume them (RTR4 §9.4; §5.2 for the
light types): one typed record per light, and its texture layout."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np


class LightType(IntEnum):
    """The light types; the values are the GLSL's LIGHT_* constants (glsl/lights/punctual.glsl)."""

    DIRECTIONAL = 0
    POINT = 1
    SPOT = 2
    # area lights (glsl/lights/area.glsl; docs/area_lights.md): local lights of a size
    RECT = 3
    DISK = 4
    SPHERE = 5
    TUBE = 6


# The area lights' types, in the order of their texel codes (AREA_CODE_BASE - k).
AREA_TYPES = (LightType.RECT, LightType.DISK, LightType.SPHERE, LightType.TUBE)


@dataclass(frozen=True)
class ShadowSettings:
    """A light's shadow map (docs/shadows.md): ``resolution`` texels a side; ``slope``: the
    shadow pass's slope-scaled depth offset (glPolygonOffset's factor); ``normal_offset``:
    how far, in shadow texels, the lighting pass moves the shaded point along its normal
    before the lookup; ``filter``: "pcf" (a 4 x 4-texel tent-box kernel), "none" or "pcss";
    ``light_size``: PCSS's light size, a point or spot light's radius in metres, the tangent
    of a directional light's angular radius; ``cascades``: a directional light's maps, each
    fitted to a slice of the camera's view (1: one map over the whole scene)."""

    resolution: int = 2048
    slope: float = 2.0
    normal_offset: float = 1.5
    filter: str = "pcf"
    light_size: float = 0.0
    cascades: int = 1


@dataclass(frozen=True)
class PunctualLight:
    """One light in world space, in float64: glsl/lights/punctual.glsl's PunctualLight.

    ``color`` is c_light (intensity included): at 1 m for point and spot lights, everywhere
    for a directional light. ``direction`` is unit, the way the light travels (directional
    and spot; zero for a point light). ``range`` is where the window falloff reaches 0
    (point and spot; directional lights ignore it). The cone cosines matter for spots only.
    """

    type: LightType
    position: np.ndarray  # (3,) world
    direction: np.ndarray  # (3,) unit
    color: np.ndarray  # (3,) linear RGB
    range: float = 1.0
    cos_outer: float = 0.0
    cos_inner: float = 1.0
    # Its shadow maps' settings where the light casts shadows (one map; six for a point;
    # one per cascade for a directional light with shadow_cascades > 1).
    shadow: ShadowSettings | None = None
    # Area lights (``AREA_TYPES``): ``color`` is then the emitted radiance L; ``position``
    # the centre; ``axis_u``, ``axis_v`` the half-extent vectors of a rectangle or disk
    # (its normal u x v the way it emits), ``axis_u`` a tube's half axis; ``radius`` a
    # sphere's, tube's (a disk's is |axis_u|). Zero for punctual lights.
    axis_u: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis_v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    radius: float = 0.0

    @property
    def is_local(self) -> bool:
        """A point, spot or area light: it reaches only the points within its range."""
        return self.type != LightType.DIRECTIONAL


# The texel values that imply a light's type (pack_lights): range < 0 marks a directional
# light, cos_outer < -1 a point light (no cone).
DIRECTIONAL_RANGE = -1.0
POINT_COS_OUTER = -2.0
# An area light's cos_outer texel: AREA_CODE_BASE - k for AREA_TYPES[k] (below -2.5);
# its other texels: centre and radius, axis_u and range, radiance (pack_lights), and
# axis_v in a texture of its own (pack_area_shapes).
AREA_CODE_BASE = -3.0


def pack_lights(lights: list[PunctualLight]) -> np.ndarray:
    """(N, 3, 4) float32 texels, the layout glsl/lights/punctual.glsl's fetch_light() reads.

    texel 0: position.xyz, cos_inner   texel 1: direction.xyz, range
    texel 2: c_light.rgb, cos_outer
    The type is implied, so a light is three fetches, not four (docs/performance.md):
    range < 0 marks a directional light, cos_outer < -1 a point light (no cone).
    """
    out = np.zeros((max(len(lights), 1), 3, 4), np.float32)
    for i, light in enumerate(lights):
        if light.type in AREA_TYPES:
            code = AREA_CODE_BASE - AREA_TYPES.index(light.type)
            out[i, 0] = (*light.position, light.radius)
            out[i, 1] = (*light.axis_u, light.range)
            out[i, 2] = (*light.color, code)
            continue
        light_range = DIRECTIONAL_RANGE if light.type == LightType.DIRECTIONAL else light.range
        cos_outer = POINT_COS_OUTER if light.type == LightType.POINT else light.cos_outer
        out[i, 0] = (*light.position, light.cos_inner)
        out[i, 1] = (*light.direction, light_range)
        out[i, 2] = (*light.color, cos_outer)
    return out


def pack_area_shapes(lights: list[PunctualLight]) -> np.ndarray:
    """(N, 4) float32: each light's axis_v (zero for the others), the texel
    glsl/lights/area.glsl's area_shape() reads beside the light's three."""
    out = np.zeros((max(len(lights), 1), 4), np.float32)
    for i, light in enumerate(lights):
        out[i, :3] = light.axis_v
    return out


def has_area_lights(lights: list[PunctualLight]) -> bool:
    """Whether any of ``lights`` is an area light (AREA_LIGHTS is compiled in)."""
    return any(light.type in AREA_TYPES for light in lights)


def order_lights(lights: list[PunctualLight]) -> list[PunctualLight]:
    """Directional lights first, then local ones, each group in scene order: the order in
    which every pass (and the twin) sums them."""
    return [x for x in lights if not x.is_local] + [x for x in lights if x.is_local]


def glsl_constants() -> dict[str, int]:
    """``LIGHT_DIRECTIONAL 0``, ``LIGHT_POINT 1``, ``LIGHT_SPOT 2``."""
    return {f"LIGHT_{t.name}": int(t) for t in LightType}
