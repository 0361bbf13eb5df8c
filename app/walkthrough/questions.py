"""Predict, then reveal: a step's questions (docs/walkthrough.md, "Questions").

A question asks the class to predict what a scene or a number will show before they look:
its prompt, its choices (or none: a short answer to say aloud), and its reveal, the answer
text with the step's view that shows it and the numbers it quotes. Every number of a
reveal is declared, not typed: a ``quantity`` the float64 twins (app/reference) compute
when the handout is built or the viewer opens the step, filled into the answer's ``{0}``,
``{1}`` ... in its ``format``. So a changed BRDF changes the answer, and
tests/test_walkthrough_questions.py recomputes each number through another path (the GLSL
the renderer runs, or the closed form) and checks the shown digits.

The quantities (each a pydantic model, ``quantity`` the discriminator):

- ``albedo``: the directional albedo R(theta) of a material (``pbs brdf``'s argument
  syntax), the white furnace's readout of RTR4 §9.3: the light a surface returns, per unit
  of a uniform white environment, seen from ``theta`` degrees off its normal;
- ``reflected``: pi f(l, v) (n.l), the radiance a surface reflects from one white light of
  c_light = 1 (RTR4 §9.4's illumination sum, one term), light and view at given angles;
- ``fresnel``: F at ``theta`` of an interface of index ``ior`` in a medium of
  ``medium_ior``, Schlick's or the exact dielectric one (RTR4 §9.5);
- ``f0``: F0 = ((n1 - n2)/(n1 + n2))^2;
- ``critical_angle``: the angle of total internal reflection, degrees;
- ``falloff``: a point light's windowed inverse-square falloff at ``distance`` over that at
  ``reference_distance`` (RTR4 §9.4, the light's ``range``);
- ``display``: the 8-bit sRGB value the post pass writes for a grey radiance, after the
  exposure and the tone map (RTR4 §9.2).
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709, as pbs brdf's plots
Channel = Literal["luminance", "r", "g", "b"]
Angle = Annotated[float, Field(ge=0.0, le=90.0)]
Positive = Annotated[float, Field(gt=0.0)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


def _channel(rgb: np.ndarray, channel: Channel) -> float:
    rgb = np.asarray(rgb, np.float64).reshape(3)
    if channel == "luminance":
        return float(rgb @ LUMINANCE)
    return float(rgb["rgb".index(channel)])


def _material(arg: str):  # -> NamedMaterial; app.brdf is imported only where a number is made
    from app.brdf.plot import parse_material_arg

    return parse_material_arg(arg)[0]


class Albedo(_Strict):
    """R(theta) of ``material``: the white furnace's readout at ``theta`` degrees."""

    quantity: Literal["albedo"]
    material: str
    theta: Angle = 0.0
    channel: Channel = "luminance"
    format: str = "{:.3f}"

    def compute(self, backend: str = "reference") -> float:
        from app.brdf.plot import albedo_curve

        curve = albedo_curve(_material(self.material), np.array([self.theta]), backend)
        return _channel(curve.albedo[0], self.channel)


def direction(theta_deg: float, phi_deg: float) -> np.ndarray:
    """A unit vector ``theta`` degrees off +Z, ``phi`` degrees about it from +X."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


class Reflected(_Strict):
    """pi f(l, v) (n.l) of ``material``: one white light's reflected radiance. The light
    is ``theta_l`` off the normal at azimuth 0, the view ``theta_v`` off it at azimuth
    ``phi`` (180: the mirror side, 0: back towards the light)."""

    quantity: Literal["reflected"]
    material: str
    theta_l: Angle
    theta_v: Angle
    phi: float = 180.0
    channel: Channel = "luminance"
    format: str = "{:.3f}"

    def compute(self, backend: str = "reference") -> float:
        from app.brdf import evaluate

        l, v = direction(self.theta_l, 0.0), direction(self.theta_v, self.phi)
        f = evaluate(_material(self.material).params, l[None], v[None], backend=backend)
        return _channel(math.pi * np.asarray(f)[0] * l[2], self.channel)


class Fresnel(_Strict):
    """F at ``theta`` degrees: light in a medium of ``medium_ior`` meeting ``ior``."""

    quantity: Literal["fresnel"]
    form: Literal["schlick", "dielectric"]
    ior: Positive
    medium_ior: Positive = 1.0
    theta: Angle
    format: str = "{:.3f}"

    def compute(self, backend: str = "reference") -> float:
        from app.common.ior import f0_from_ior
        from app.reference.fresnel import F_dielectric, F_schlick

        cos = math.cos(math.radians(self.theta))
        if self.form == "schlick":
            f0 = f0_from_ior(np.float64(self.ior), self.medium_ior)
            return float(np.asarray(F_schlick(np.array([f0]), np.float64(cos))).reshape(-1)[0])
        return float(F_dielectric(np.float64(self.ior / self.medium_ior), np.float64(cos)))


class F0(_Strict):
    """F0 of an interface of ``ior`` in a medium of ``medium_ior``."""

    quantity: Literal["f0"]
    ior: Positive
    medium_ior: Positive = 1.0
    format: str = "{:.3f}"

    def compute(self, backend: str = "reference") -> float:
        from app.common.ior import f0_from_ior

        return float(f0_from_ior(np.float64(self.ior), self.medium_ior))


class CriticalAngle(_Strict):
    """The critical angle, degrees, for light inside ``ior`` meeting ``medium_ior``."""

    quantity: Literal["critical_angle"]
    ior: Positive
    medium_ior: Positive = 1.0
    format: str = "{:.1f}"

    @model_validator(mode="after")
    def _internal(self) -> CriticalAngle:
        if self.medium_ior >= self.ior:
            raise ValueError("medium_ior: total internal reflection needs medium_ior < ior")
        return self

    def compute(self, backend: str = "reference") -> float:
        from app.reference.fresnel import critical_cos

        return math.degrees(math.acos(float(critical_cos(np.float64(self.medium_ior / self.ior)))))


class Falloff(_Strict):
    """A point light's falloff at ``distance`` relative to ``reference_distance``: the
    inverse square times the window to zero at ``range`` (glsl/lights/punctual.glsl)."""

    quantity: Literal["falloff"]
    distance: Positive
    reference_distance: Positive = 1.0
    range: Positive
    format: str = "{:.3f}"

    def compute(self, backend: str = "reference") -> float:
        from app.reference.punctual import window_falloff

        def at(d: float) -> float:
            return float(window_falloff(np.float64(d * d), self.range)) / (d * d)

        return at(self.distance) / at(self.reference_distance)


class Display(_Strict):
    """The 8-bit display value of a grey ``radiance`` after ``exposure`` EV and ``tonemap``
    (glsl/passes/post.frag's twin)."""

    quantity: Literal["display"]
    radiance: Annotated[float, Field(ge=0.0)]
    exposure: float = 0.0
    tonemap: Literal["linear", "neutral", "aces", "reinhard"] = "linear"
    format: str = "{:.0f}"

    def compute(self, backend: str = "reference") -> float:
        from app.reference.tonemap import post_process

        c = post_process(np.full((1, 3), self.radiance), self.exposure, self.tonemap)
        return float(np.round(np.clip(c[0, 0], 0.0, 1.0) * 255.0))


Quantity = Annotated[
    Albedo | Reflected | Fresnel | F0 | CriticalAngle | Falloff | Display,
    Field(discriminator="quantity"),
]

_VALUES: dict[str, float] = {}


def value(number: Albedo | Reflected | Fresnel | F0 | CriticalAngle | Falloff | Display) -> float:
    """The number the twins compute for ``number`` (cached per declaration in the process:
    the handout and the viewer ask again for the same ones)."""
    key = number.model_dump_json()
    if key not in _VALUES:
        _VALUES[key] = number.compute("reference")
    return _VALUES[key]


def formatted(numbers: list) -> list[str]:
    """Each number computed and written in its ``format``: what the reveal shows."""
    return [n.format.format(value(n)) for n in numbers]
