"""The scene-file schema (TOML), validated with pydantic.

Every key, its unit and its default is documented in docs/scene-format.md; this module
is the single place they are defined. Models forbid unknown keys and non-finite
numbers, and accept only the types the documentation names (no "1.0" for 1.0).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidatorFunctionWrapHandler,
    field_serializer,
    field_validator,
    model_validator,
)

from app.common.gbuffer import DEFAULT_ENCODING, ENCODING_NAMES
from app.common.ior import f0_from_ior, ior_from_f0
from app.common.material_checks import MAP_KEYS, MAX_RADIANCE, material_problems
from app.common.material_fields import FIELDS, scene_default, scene_keys
from app.common.models import (
    CLOTH_WRAP_FORMS,
    CORRELATIONS,
    DIFFRACTION_MODELS,
    DIFFUSE_MODELS,
    FIBER_MODELS,
    FRESNEL_MODELS,
    G2_MODELS,
    LAMBDA_FORMS,
    NDF_MODELS,
    SHEEN_MODELS,
    MaterialParams,
    Model,
    ModelParams,
)
from app.common.tonemaps import TONEMAPS
from app.reference.filtering import SPECULAR_AA_KAPPA, SPECULAR_AA_SIGMA2
from app.scene.presets import PRESETS

Real = Annotated[float, Field(strict=True, allow_inf_nan=False)]
# Coordinates and lengths stop at 1e6 m: trimesh squares lengths (a sphere of radius
# 1e300 became NaN vertices, an object that silently vanished; found by
# tests/test_fuzz_scenes.py), and float32 positions are useless far beyond.
MAX_LENGTH = 1e6
Vec3 = Annotated[
    list[Annotated[Real, Field(ge=-MAX_LENGTH, le=MAX_LENGTH)]], Field(min_length=3, max_length=3)
]
# Radiometric values (light colours and intensities, background, environment radiance,
# emission) stop at MAX_RADIANCE (1e15; app/common/material_checks.py says why), so that
# the HDR image stays finite in float32.
# Entries of a scene's tables (docs/stability.md, "Limits"): far past any scene of the
# project's (the bench's largest has 256 lights), and within what the passes can hold: a
# light is three texels of one row of the lighting pass's light texture (at most 16384
# wide on llvmpipe), every object at least one drawn part (Limits.max_parts).
MAX_LIGHTS = 4096
MAX_OBJECTS = 16_384
MAX_MATERIALS = 4096
Color = Annotated[
    list[Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)]], Field(min_length=3, max_length=3)
]
UnitColor = Annotated[
    list[Annotated[Real, Field(ge=0.0, le=1.0)]], Field(min_length=3, max_length=3)
]
Unit = Annotated[Real, Field(ge=0.0, le=1.0)]
Positive = Annotated[Real, Field(gt=0.0, le=MAX_LENGTH)]  # metres (or a scale factor)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


def _nonzero(v: list[float] | None, what: str) -> None:
    if v is not None and math.fsum(x * x for x in v) <= 1e-20:
        raise ValueError(f"{what}: must not be the zero vector")


FileIndex = Annotated[int, Field(strict=True, ge=0)]
# What a glTF camera (camera.from_file) gives; each of these keys given beside it wins.
FILE_CAMERA_KEYS = ("position", "target", "up", "fov_y", "near", "far")


class Camera(_Strict):
    """A pinhole camera looking from ``position`` at ``target``."""

    position: Vec3 = [0.0, 1.0, 6.0]
    target: Vec3 = [0.0, 0.0, 0.0]
    up: Vec3 = [0.0, 1.0, 0.0]
    fov_y: Annotated[Real, Field(gt=0.0, lt=180.0)] = 45.0  # degrees, vertical
    exposure: Annotated[Real, Field(ge=-32.0, le=32.0)] = 0.0  # EV: radiance x 2^exposure
    near: Positive = 0.05  # metres
    far: Positive = 200.0  # metres
    # RTR4 §9.2: a thin lens of this diameter (metres; 0 = a pinhole, everything
    # sharp) focused at focus_distance (metres along the view axis; default: the target's).
    aperture: Annotated[Real, Field(ge=0.0, le=10.0)] = 0.0
    focus_distance: Positive | None = None
    # A glTF file's camera (docs/gltf-lights-cameras.md): its name (or its node's), or its
    # index in the file's cameras; ``object`` names the glTF object (name or index in
    # [[objects]]) when several are. Resolved at load (app/scene/gltf_lights_cameras.py);
    # FILE_CAMERA_KEYS given beside it replace the file's values (an orbit, a sweep).
    from_file: Annotated[str, Field(min_length=1)] | FileIndex | None = None
    object: Annotated[str, Field(min_length=1)] | FileIndex | None = None

    @model_validator(mode="after")
    def _check(self) -> Camera:
        if self.from_file is not None:  # checked whole once resolved (app/scene/loader.py)
            if (
                self.aperture > 0.0
                and self.focus_distance is None
                and "target" not in (self.model_fields_set)
            ):
                raise ValueError(
                    "focus_distance: a camera from a file has no target to focus on; "
                    "give focus_distance (or target) with aperture"
                )
            return self
        if self.object is not None:
            raise ValueError("object: applies only with from_file")
        forward = np.subtract(self.target, self.position)
        if math.fsum(x * x for x in forward) <= 1e-20:
            raise ValueError("target: must differ from position (no view direction)")
        _nonzero(self.up, "up")
        if np.linalg.norm(np.cross(forward, self.up)) <= 1e-9 * np.linalg.norm(forward):
            raise ValueError("up: must not be parallel to the view direction (target - position)")
        if self.far <= self.near:
            raise ValueError("far: must be greater than near")
        return self

    @property
    def focus(self) -> float:
        """The focus distance in metres: focus_distance, or the target's view depth."""
        if self.focus_distance is not None:
            return float(self.focus_distance)
        return float(np.linalg.norm(np.subtract(self.target, self.position)))


# The antialiasing a scene that leaves render.antialiasing unset gets (docs/antialiasing.md,
# "The choice").
DEFAULT_ANTIALIASING = "gbaa"


class RenderSettings(_Strict):
    """Image size and pipeline options."""

    width: Annotated[int, Field(strict=True, ge=1, le=16384)] = 1280
    height: Annotated[int, Field(strict=True, ge=1, le=16384)] = 720
    tonemap: Literal[TONEMAPS] = "neutral"  # type: ignore[valid-type]
    # The G-buffer's storage (app/common/gbuffer.py ENCODINGS; docs/gbuffer.md measures each).
    gbuffer: Literal[ENCODING_NAMES] = DEFAULT_ENCODING  # type: ignore[valid-type]
    # "auto": tiles only from app/render/culling.py TILED_MIN_LOCAL_LIGHTS local lights on.
    light_culling: Literal["auto", "tiled", "none"] = "auto"
    # RTR4 §9.13: how normal-map mips carry the variance of the normals they average
    # into roughness (app/textures/mips.py; "lean": as an anisotropic covariance,
    # app/textures/lean.py; "auto": lean for a map whose spread keeps a direction, else
    # variance), and screen-space geometric specular AA.
    normal_filter: Literal["none", "naive", "toksvig", "variance", "lean", "auto"] = "auto"
    specular_aa: Annotated[bool, Field(strict=True)] = False
    # Tokuyoshi & Kaplanyan 2019's sigma^2 (pixel filter) and kappa (the most alpha^2 the
    # filter may add), as the twin defines them (app/reference/filtering.py).
    specular_aa_variance: Annotated[Real, Field(gt=0.0, le=10.0)] = SPECULAR_AA_SIGMA2
    specular_aa_threshold: Unit = SPECULAR_AA_KAPPA
    blend: Literal["runtime", "baked"] = "runtime"  # mask blends mixed per pixel, or baked
    supersample: Annotated[int, Field(strict=True, ge=1, le=16)] = 1  # n x n samples per pixel
    # Antialiasing (docs/antialiasing.md, which measures the choice): "none"; "fxaa", a
    # luma-edge filter of the display image (after Lottes' FXAA 3.11); "jitter", the mean
    # of antialiasing_samples frames with the projection jittered by Halton (2, 3)
    # sub-pixel offsets; "sraa", subpixel reconstruction from 4 geometry samples per
    # pixel; "gbaa", the silhouettes resolved from each pixel's distance to its surface's
    # edge, written by the G-buffer pass (app/render/antialias.py); "msaa", a 4-sample
    # G-buffer shaded per sample where a pixel's samples differ (app/render/msaa.py).
    # Unset (None), DEFAULT_ANTIALIASING, or "fxaa" past a triangle count
    # (Renderer.antialiasing): None rather than a default value, so a table dumped and
    # validated again by an edit keeps meaning "not named".
    antialiasing: Literal["none", "fxaa", "jitter", "sraa", "gbaa", "msaa"] | None = None
    antialiasing_samples: Annotated[int, Field(strict=True, ge=1, le=256)] = 8
    # "gbaa" in a still (not the viewer's frames): every pixel inside a surface also moved
    # from its centre's radiance to its area mean (docs/antialiasing.md); unset (None, the
    # default), only where no opaque surface samples a texture map (Renderer.gbaa_interior):
    # None rather than a default of true, so a table dumped and validated again by an edit
    # keeps meaning "not named"
    gbaa_interior: Annotated[bool | None, Field(strict=True)] = None
    # RTR4 §9.1: the surface (specular) and subsurface (diffuse) reflections as
    # separate contributions: both, or one of them alone.
    terms: Literal["all", "specular", "diffuse"] = "all"
    # What pixels no surface covers hold: "opaque", the scene's background colour (or its
    # environment, [environment] background = true); "transparent", nothing: alpha is the
    # antialiased coverage, and the PNG is RGBA with straight alpha (docs/scene-format.md).
    background: Literal["opaque", "transparent"] = "opaque"

    def drawn_size(self, size: tuple[int, int] | None = None) -> tuple[int, int]:
        """The pixels every pass before the resolve runs at for an image of ``size``
        (default ``width`` x ``height``): each side times ``supersample``."""
        width, height = size or (self.width, self.height)
        return width * self.supersample, height * self.supersample

    @model_validator(mode="after")
    def _check(self) -> RenderSettings:
        if max(self.width, self.height) * self.supersample > 16384:
            raise ValueError(
                "supersample: width and height times supersample must not exceed 16384"
            )
        return self


# The widest spot cone a shadow map covers (half-angle, degrees): one square perspective
# frustum of 2 x (80 + 1) degrees (app/render/shadows.py adds a degree a side) already
# spreads its texels 41 times (1 / cos^2 81 degrees) wider at the edge than at the centre.
MAX_SHADOW_SPOT_ANGLE = 80.0


# The area lights' types (docs/area_lights.md): shapes of a size, shaded by LTC.
AREA_LIGHT_TYPES = ("rect", "disk", "sphere", "tube")


class Light(_Strict):
    """A punctual or area light. ``c_light = color * intensity`` (at 1 m for point and spot
    lights); an area light emits the radiance that gives a point light of that c_light's
    power (docs/area_lights.md)."""

    type: Literal["directional", "point", "spot", "rect", "disk", "sphere", "tube"]
    color: Color = [1.0, 1.0, 1.0]
    intensity: Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)] = 1.0
    position: Vec3 | None = None
    direction: Vec3 | None = None
    range: Positive | None = None  # metres; the window reaches exactly 0 here
    inner_angle: Annotated[Real, Field(ge=0.0, lt=90.0)] | None = None  # degrees, half-angle
    outer_angle: Annotated[Real, Field(gt=0.0, le=90.0)] | None = None  # degrees, half-angle
    # Area lights: a rectangle's [width, height] (its width horizontal, across direction),
    # a disk's, sphere's or tube's radius, a tube's length along its direction (metres).
    size: Annotated[list[Positive], Field(min_length=2, max_length=2)] | None = None
    radius: Positive | None = None
    length: Positive | None = None
    # Shadow maps (docs/shadows.md); a point light's are six cube faces.
    shadow: Annotated[bool, Field(strict=True)] = False
    shadow_resolution: Annotated[int, Field(strict=True, ge=16)] = 2048  # texels a side
    # [slope, normal]: the shadow pass's slope-scaled depth offset (glPolygonOffset's factor,
    # in depth slopes) and the lighting pass's normal offset (in shadow texels).
    shadow_bias: Annotated[
        list[Annotated[Real, Field(ge=0.0, le=100.0)]], Field(min_length=2, max_length=2)
    ] = [2.0, 1.5]
    shadow_filter: Literal["pcf", "none", "pcss"] = "pcf"
    # PCSS's light size (Fernando 2005): a point or spot light's radius in metres, a
    # directional light's angular radius in degrees (the sun's is about 0.27).
    shadow_light_radius: Annotated[Real, Field(gt=0.0, le=10.0)] = 0.05
    shadow_light_angle: Annotated[Real, Field(gt=0.0, le=10.0)] = 0.27
    # A directional light's cascades (docs/shadows.md): maps fitted to slices of the view.
    shadow_cascades: Annotated[int, Field(strict=True, ge=1, le=4)] = 1

    @model_validator(mode="after")
    def _check(self) -> Light:
        needs = {
            "directional": {"direction"},
            "point": {"position"},
            "spot": {"position", "direction"},
            "rect": {"position", "direction", "size"},
            "disk": {"position", "direction", "radius"},
            "sphere": {"position", "radius"},
            "tube": {"position", "direction", "radius", "length"},
        }[self.type]
        allowed = needs | {
            "directional": set(),
            "point": {"range"},
            "spot": {"range", "inner_angle", "outer_angle"},
        }.get(self.type, {"range"})
        for key in sorted(needs):
            if getattr(self, key) is None:
                raise ValueError(f"{key}: a {self.type} light needs it")
        if self.shadow and self.type in AREA_LIGHT_TYPES:
            raise ValueError(f"shadow: a {self.type} light casts no shadow map")
        keys = ("position", "direction", "range", "inner_angle", "outer_angle", "size", "radius")
        for key in (*keys, "length"):
            if key not in allowed and getattr(self, key) is not None:
                raise ValueError(f"{key}: does not apply to a {self.type} light")
        _nonzero(self.direction, "direction")
        if max(self.color) * self.intensity > MAX_RADIANCE:  # c_light, see MAX_RADIANCE
            raise ValueError(f"intensity: color x intensity must not exceed {MAX_RADIANCE:g}")
        if self.type == "spot" and self.cone[0] >= self.cone[1]:
            raise ValueError("inner_angle: must be smaller than outer_angle")
        if self.shadow and self.type == "spot" and self.cone[1] > MAX_SHADOW_SPOT_ANGLE:
            raise ValueError(
                f"shadow: a spot's shadow map (one perspective frustum) covers an outer_angle "
                f"up to {MAX_SHADOW_SPOT_ANGLE:g} degrees"
            )
        # A shadow key set to other than its default needs shadow = true (compared by value,
        # not by which keys were written, so a dumped and re-validated scene stays valid).
        for key in ("shadow_resolution", "shadow_bias", "shadow_filter"):
            if not self.shadow and getattr(self, key) != Light.model_fields[key].default:
                raise ValueError(f"{key}: needs shadow = true")
        if self.shadow_cascades != 1:
            if self.type != "directional":
                raise ValueError(f"shadow_cascades: does not apply to a {self.type} light")
            if not self.shadow:
                raise ValueError("shadow_cascades: needs shadow = true")
        # The light size: for PCSS only, and the one of the light's kind.
        size_key = "shadow_light_angle" if self.type == "directional" else "shadow_light_radius"
        for key in ("shadow_light_radius", "shadow_light_angle"):
            if getattr(self, key) == Light.model_fields[key].default:
                continue
            if key != size_key:
                raise ValueError(f"{key}: does not apply to a {self.type} light (use {size_key})")
            if not (self.shadow and self.shadow_filter == "pcss"):
                raise ValueError(f'{key}: needs shadow = true and shadow_filter = "pcss"')
        return self

    @property
    def cone(self) -> tuple[float, float]:
        """(inner, outer) half-angles in degrees, defaults filled in."""
        inner = 20.0 if self.inner_angle is None else self.inner_angle
        outer = 30.0 if self.outer_angle is None else self.outer_angle
        return inner, outer

    @property
    def effective_range(self) -> float:
        """The range in metres (default 10 m); infinite for directional lights."""
        if self.type == "directional":
            return math.inf
        return 10.0 if self.range is None else self.range


Ior = Annotated[Real, Field(ge=1.0, le=10.0)]
# Scene keys whose lower bound is excluded: a conductor's refractive index n is positive.
_EXCLUSIVE_LOW = frozenset({"eta", "attenuation_distance"})


def _table_key(name: str) -> Any:
    """The schema type of material-table scene key ``name``: a number, or a list of as
    many numbers as its default has, each within the bounds app/common/material_fields.py
    declares for it (pydantic's own messages name them)."""
    key = scene_keys()[name]
    low = {"gt": key.low} if name in _EXCLUSIVE_LOW else {"ge": key.low}
    number = Annotated[Real, Field(**low, le=key.high)]
    default = scene_default(name)
    if isinstance(default, float):
        return number
    size = len(default)
    return Annotated[list[number], Field(min_length=size, max_length=size)]  # type: ignore[valid-type]


TexturePath = Annotated[str, Field(min_length=1, max_length=4096)]
UvScale = Annotated[list[Annotated[Real, Field(gt=0.0, le=1e4)]], Field(min_length=2, max_length=2)]

# Material keys that name texture files (relative to the scene file), and what they hold.
TEXTURE_KEYS = {
    "base_color_map": "sRGB colour; multiplies base_color",
    "metallic_map": "linear, red channel; multiplies metallic",
    "roughness_map": "linear, red channel; multiplies roughness",
    "normal_map": "tangent-space normals, RGB = n * 0.5 + 0.5 (OpenGL: +Y along +v)",
    "anisotropy_map": "linear, red channel; multiplies anisotropy",
    # glTF KHR_materials_anisotropy's anisotropyTexture RG (RTR4 §9.8)
    "anisotropy_direction_map": (
        "linear RG: the direction of anisotropy 2 rg - 1 in (tangent, bitangent), turned by "
        "anisotropy_rotation"
    ),
    # glTF KHR_materials_clearcoat's clearcoatNormalTexture (RTR4 §9.12)
    "clearcoat_normal_map": "the clear coat's own tangent-space normals, as normal_map",
    # glTF 2.0 core material: emissiveTexture and occlusionTexture
    "emissive_map": "sRGB colour; multiplies emissive (emitted radiance)",
    "occlusion_map": "linear, red channel; darkens environment light only",
}
# glTF 2.0 alphaMode, lower case: "blend" parts are shaded forward and composited over the
# lit image after the lighting pass (app/render/blend.py, docs/scene-format.md).
ALPHA_MODES = ("opaque", "mask", "blend")
EmissiveColor = Annotated[
    list[Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)]], Field(min_length=3, max_length=3)
]


class Blend(_Strict):
    """Paints another material over this one where a mask texture says so (RTR4 §9.13):
    the two materials' parameters are mixed with weight ``smoothstep`` of the mask around
    ``threshold`` over a ramp ``softness`` wide, never their shaded colours."""

    material: str  # name in [materials]: the layer painted on top
    mask: TexturePath  # linear, red channel, sampled with this material's UVs
    threshold: Unit = 0.5
    softness: Unit = 0.1  # width of the ramp in mask units; 0 = a hard edge


# Empirical cloth (RTR4 §9.10): a lobe's weight k and exponent a (a > 0: pow(0, a) is
# defined in GLSL only for a > 0).
CLOTH_KEYS = (
    "cloth_rim", "cloth_inner", "cloth_diffuse", "cloth_scatter", "cloth_wrap", "cloth_sheen",
    "cloth_sheen_color", "cloth_wrap_form",
)  # fmt: skip
# Micro-cylinder fibres (RTR4 §9.10): every key needs a fibre model; the last two are
# Sadeghi et al.'s alone.


def _given(value: Any, key: str) -> Any:
    """``value`` of scene key ``key``, or where unset (None) the key's default, declared
    with its material field (app/common/material_fields.py)."""
    return scene_default(key) if value is None else value


FIBER_KEYS = ("fiber_rotation", "fiber_curvature", "fiber_gamma_v", "fiber_kd")
SADEGHI_KEYS = ("fiber_gamma_v", "fiber_kd")


class Material(_Strict):
    """The metallic-roughness material (glTF names), optionally from a preset (RTR4's F0
    tables), and the model of each BRDF term (docs/scene-format.md, "Materials")."""

    preset: str | None = None
    base_color: UnitColor | None = None  # linear RGB
    metallic: Unit | None = None
    roughness: Unit | None = None  # perceptual; alpha = roughness^2
    f0: Unit | None = None  # dielectric F0; or give ior
    ior: Ior | None = None  # the object's index of refraction
    medium_ior: Ior | None = None  # the index of the medium around it (1.0 air, 1.33 water)
    anisotropy: Annotated[Real, Field(ge=-1.0, le=1.0)] | None = None
    # Model of each term (RTR4 §9.5–9.9); the defaults are the standard model.
    fresnel: Literal[FRESNEL_MODELS] = "schlick"  # type: ignore[valid-type]
    f90: _table_key("f90") | None = None  # schlick_generalized
    fresnel_p: _table_key("fresnel_p") | None = None  # exponent 1/p
    eta: _table_key("eta") | None = None  # conductor: n per RGB channel
    k: _table_key("k") | None = None  # conductor: k per RGB channel
    ndf: Literal[NDF_MODELS] = "ggx"  # type: ignore[valid-type]
    gtr_gamma: _table_key("gtr_gamma") | None = None
    specular_color: _table_key("specular_color") | None = None  # the dielectric F0's colour
    lambda_form: Literal[LAMBDA_FORMS] = "exact"  # type: ignore[valid-type]
    g2: Literal[G2_MODELS] = "height_correlated"  # type: ignore[valid-type]
    correlation: Literal[CORRELATIONS] = "exp"  # type: ignore[valid-type]
    diffuse: Literal[DIFFUSE_MODELS] = "lambert"  # type: ignore[valid-type]
    multiscatter: Annotated[bool, Field(strict=True)] = False
    # --- thin film (RTR4 §9.11): a dielectric film over the base replaces its F ---
    thin_film: Annotated[bool, Field(strict=True)] = False
    film_thickness: _table_key("film_thickness") | None = None  # nm (default 400)
    film_ior: _table_key("film_ior") | None = None  # the film's index (default 1.33, water/soap)
    # Sheen (RTR4 §9.10): a cloth layer over the material above. No sheen_color (or black)
    # means no layer, compiled out; sheen picks the NDF ("none" turns a layer off).
    sheen: Literal[SHEEN_MODELS] = "charlie"  # type: ignore[valid-type]
    sheen_color: _table_key("sheen_color") | None = None  # linear RGB
    # perceptual; alpha = sheen_roughness^2; default 0.5
    sheen_roughness: _table_key("sheen_roughness") | None = None
    # --- clear coat (RTR4 §9.12; docs/layered.md) ---
    # strength; 0 = no coat (compiled out)
    clearcoat: _table_key("clearcoat") = FIELDS["clearcoat"].default
    # perceptual (default 0: a polished coat)
    clearcoat_roughness: _table_key("clearcoat_roughness") | None = None
    # the coat's index (default 1.5), >= medium_ior
    clearcoat_ior: _table_key("clearcoat_ior") | None = None
    # transmittance at normal incidence, once
    clearcoat_color: _table_key("clearcoat_color") | None = None
    # how the coat composes with the base (docs/layered.md): Filament's or Weidlich & Wilkie's
    clearcoat_model: Literal["filament", "weidlich_wilkie", "weidlich_wilkie_series"] = "filament"
    # The coat's own normal map (glTF clearcoatNormalTexture; docs/layered.md): without it
    # the coat keeps the vertex normal, whatever normal map the base has.
    clearcoat_normal_map: TexturePath | None = None
    clearcoat_normal_scale: Annotated[Real, Field(ge=0.0, le=10.0)] | None = None  # default 1
    # --- empirical cloth (RTR4 §9.10): only with diffuse = "cloth_empirical" ---
    cloth_rim: _table_key("cloth_rim") | None = None  # [k_rim, a_rim] (default [0, 1])
    cloth_inner: _table_key("cloth_inner") | None = None  # [k_inner, a_inner] (default [0, 1])
    cloth_diffuse: _table_key("cloth_diffuse") | None = None  # k_diff (default 1)
    # c_scatter, linear RGB (default white: none)
    cloth_scatter: _table_key("cloth_scatter") | None = None
    cloth_wrap: _table_key("cloth_wrap") | None = None  # w (default 0: no wrap)
    # the wrapped cosine: "filament" (default, conserves energy) or "rtr4" (the book's)
    cloth_wrap_form: Literal[CLOTH_WRAP_FORMS] | None = None  # type: ignore[valid-type]
    cloth_sheen: _table_key("cloth_sheen") | None = None  # k_sheen (default 0)
    # c_sheen, linear RGB (default white)
    cloth_sheen_color: _table_key("cloth_sheen_color") | None = None
    # --- diffraction (RTR4 §9.11; docs/diffraction.md): a grating, grooves along the tangent
    diffraction: Literal[DIFFRACTION_MODELS] = "none"  # type: ignore[valid-type]
    grating_period: _table_key("grating_period") | None = None  # nm (1600)
    grating_depth: _table_key("grating_depth") | None = None  # nm (120)
    # --- micro-cylinder fibres (RTR4 §9.10; docs/cloth.md "Micro-cylinder"): a thread along
    # the tangent replaces the specular and diffuse terms; angles in degrees
    fiber: Literal[FIBER_MODELS] = "none"  # type: ignore[valid-type]
    fiber_rotation: _table_key("fiber_rotation") | None = None  # about n (0)
    fiber_curvature: _table_key("fiber_curvature") | None = None  # largest tilt (0)
    fiber_gamma_v: _table_key("fiber_gamma_v") | None = None  # sadeghi (20)
    # sadeghi: isotropic share of the volume scattering (0.3)
    fiber_kd: _table_key("fiber_kd") | None = None
    # Transmission and volume (RTR4 §14.5; glTF KHR_materials_transmission/volume): the
    # refracted share of the dielectric base (0), the volume's thickness in object units
    # (0: thin-walled), Beer-Lambert's colour at a distance (white; unset: no attenuation)
    transmission: _table_key("transmission") | None = None
    thickness: _table_key("thickness") | None = None
    attenuation_color: _table_key("attenuation_color") | None = None
    attenuation_distance: _table_key("attenuation_distance") | None = None
    dispersion: _table_key("dispersion") | None = None  # 20 / Abbe number (0)
    # Textures (RTR4 §9.13), paths relative to the scene file; see TEXTURE_KEYS.
    base_color_map: TexturePath | None = None
    metallic_map: TexturePath | None = None
    roughness_map: TexturePath | None = None
    normal_map: TexturePath | None = None
    anisotropy_map: TexturePath | None = None
    # glTF KHR_materials_anisotropy (RTR4 §9.8): the direction of anisotropy turned about n,
    # counter-clockwise from the tangent towards the bitangent, in degrees (0), and a map of
    # that direction; the base material's only (a blend's top layer keeps the base's)
    anisotropy_rotation: Annotated[Real, Field(ge=-360.0, le=360.0)] = 0.0
    anisotropy_direction_map: TexturePath | None = None
    normal_scale: Annotated[Real, Field(ge=0.0, le=10.0)] = 1.0  # glTF normalTexture.scale
    uv_scale: UvScale = [1.0, 1.0]  # texture repeats across the surface's UV range
    blend: Blend | None = None
    # --- glTF 2.0 core material (docs/scene-format.md) ---
    emissive: EmissiveColor | None = None  # emitted radiance, linear RGB (W/(sr m^2))
    emissive_strength: Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)] = 1.0  # multiplies it
    emissive_map: TexturePath | None = None
    occlusion_map: TexturePath | None = None
    occlusion_strength: Unit | None = None  # glTF occlusionTexture.strength (default 1)
    alpha: Unit = 1.0  # coverage (glTF baseColorFactor's A), times the base colour map's A
    alpha_mode: Literal[ALPHA_MODES] = "opaque"  # type: ignore[valid-type]
    alpha_cutoff: Unit | None = None  # "mask" only (default 0.5)

    @model_validator(mode="after")
    def _check(self) -> Material:
        """The keys as written (which go together, which need which): the scene file's
        own rules. What the keys resolve to is checked last, by the checks every material
        front-end shares (``_check_resolved``)."""
        if self.anisotropy_rotation and not self.anisotropy:
            raise ValueError("anisotropy_rotation: turns the anisotropy, which must be non-zero")
        if self.preset is not None and self.preset not in PRESETS:
            raise ValueError(
                f"preset: unknown preset '{self.preset}' (known: {', '.join(sorted(PRESETS))})"
            )
        if self.f0 is not None and self.ior is not None:
            raise ValueError("ior: give either 'f0' or 'ior', not both")
        only = {
            "f90": ("fresnel", "schlick_generalized"),
            "fresnel_p": ("fresnel", "schlick_generalized"),
            "eta": ("fresnel", "conductor"),
            "k": ("fresnel", "conductor"),
            "gtr_gamma": ("ndf", "gtr"),
            "film_thickness": ("thin_film", True),  # thin film (RTR4 §9.11)
            "film_ior": ("thin_film", True),
            "grating_period": ("diffraction", "grating"),  # diffraction (RTR4 §9.11)
            "grating_depth": ("diffraction", "grating"),
        }
        for key, (term, value) in only.items():
            if getattr(self, key) is not None and getattr(self, term) != value:
                shown = "true" if value is True else f"'{value}'"
                raise ValueError(f"{key}: applies only with {term} = {shown}")
        if self.sheen_roughness is not None and self.sheen_color is None:  # sheen
            raise ValueError("sheen_roughness: applies only with a 'sheen_color'")
        if self.specular_color is not None and self.fresnel in ("dielectric", "conductor"):
            raise ValueError(  # the exact Fresnel models take the index, not an F0
                "specular_color: applies only with fresnel = 'schlick' or 'schlick_generalized'"
            )
        self._check_clearcoat()
        self._check_core()
        self._check_fiber()
        for key in CLOTH_KEYS:  # empirical cloth (RTR4 §9.10)
            if getattr(self, key) is not None and self.diffuse != "cloth_empirical":
                raise ValueError(f"{key}: applies only with diffuse = 'cloth_empirical'")
        for key in ("cloth_rim", "cloth_inner"):
            lobe = getattr(self, key)
            if lobe is not None and lobe[0] > 10.0:
                raise ValueError(f"{key}: the weight k must be at most 10")
            if lobe is not None and lobe[1] <= 0.0:
                raise ValueError(f"{key}: the exponent must be positive")
        if self.fresnel == "conductor" and self._conductor_index() is None:
            raise ValueError(
                "fresnel: 'conductor' needs 'eta' and 'k' (or a metal preset that has them)"
            )
        self._check_resolved()
        return self

    def _check_resolved(self) -> None:
        """The material these keys resolve to, with the maps they name, through the
        checks the glTF and MTL front-ends run on theirs (app/common/material_checks.py):
        the first problem, named by its key."""
        maps = [role for role, key in MAP_KEYS.items() if getattr(self, key) is not None]
        emissive = self.emissive or (0.0, 0.0, 0.0)
        problems = material_problems(self.resolve(), maps, emissive, self.emissive_strength)
        if problems:
            raise ValueError(f"{problems[0].key}: {problems[0].message}")

    def _check_core(self) -> None:
        """glTF core material keys that need another key to mean anything."""
        if self.occlusion_strength is not None and self.occlusion_map is None:
            raise ValueError("occlusion_strength: applies only with an 'occlusion_map'")
        if self.alpha_cutoff is not None and self.alpha_mode != "mask":
            raise ValueError("alpha_cutoff: applies only with alpha_mode = 'mask'")

    @property
    def emission(self) -> tuple[float, float, float]:
        """Emitted radiance, linear RGB: emissive x emissive_strength (black without)."""
        e = self.emissive or (0.0, 0.0, 0.0)
        return (e[0] * self.emissive_strength, e[1] * self.emissive_strength,
                e[2] * self.emissive_strength)  # fmt: skip

    def _check_fiber(self) -> None:
        """Fibre keys (RTR4 §9.10) need their model. (A fibre replaces the specular and
        diffuse terms: the terms and layers it refuses are the resolved checks'; a
        ``sheen_color`` that makes no layer is refused here as a key that does not apply.)"""
        for key in FIBER_KEYS:
            if getattr(self, key) is not None and self.fiber == "none":
                raise ValueError(f"{key}: applies only with fiber = 'kajiya_kay' or 'sadeghi'")
        for key in SADEGHI_KEYS:
            if getattr(self, key) is not None and self.fiber != "sadeghi":
                raise ValueError(f"{key}: applies only with fiber = 'sadeghi'")
        layer = self.sheen != "none" and max(self.sheen_color or (0.0,)) > 0.0
        if self.fiber != "none" and self.sheen_color is not None and not layer:
            raise ValueError(
                f"sheen_color: does not apply with fiber = '{self.fiber}' (the fibre replaces "
                "the specular and diffuse terms; no other layer composes over it)"
            )

    def _check_clearcoat(self) -> None:
        """Clear coat keys (RTR4 §9.12) need a coat. (Its normal map without a coat, and
        a coat its base or the medium cannot hold, are the resolved checks'.)"""
        if self.clearcoat == 0.0:
            for key in ("clearcoat_roughness", "clearcoat_ior", "clearcoat_color"):
                if getattr(self, key) is not None:
                    raise ValueError(f"{key}: applies only with clearcoat > 0")
            if self.clearcoat_normal_map is None and self.clearcoat_normal_scale is not None:
                raise ValueError("clearcoat_normal_scale: applies only with clearcoat > 0")
            # clearcoat_model is not checked: without a coat it selects nothing, and tools
            # that rebuild a material from all its fields (pbs compare) set it explicitly.
            return
        if self.clearcoat_normal_scale is not None and self.clearcoat_normal_map is None:
            raise ValueError("clearcoat_normal_scale: applies only with a 'clearcoat_normal_map'")

    def _medium(self) -> float:
        """The index of the medium around the object (medium_ior, the preset's, or air)."""
        if self.medium_ior is not None:
            return self.medium_ior
        return float(getattr(self._preset(), "medium_ior", 1.0))

    def _preset(self) -> object | None:
        return PRESETS[self.preset] if self.preset is not None else None

    def _conductor_index(self) -> tuple[np.ndarray, np.ndarray] | None:
        p = self._preset()
        eta = self.eta if self.eta is not None else getattr(p, "eta", None)
        k = self.k if self.k is not None else getattr(p, "k", None)
        if eta is None or k is None:
            return None
        return np.asarray(eta, np.float64), np.asarray(k, np.float64)

    def resolve(self) -> MaterialParams:
        """Apply preset, then explicit keys, then defaults (grey plastic, F0 = 0.04); then
        the clear coat (RTR4 §9.12), whose index is relative to the medium like the rest."""
        params = self.resolve_base()
        if self.clearcoat == 0.0:
            return params
        medium = self._medium()
        coat_ior = _given(self.clearcoat_ior, "clearcoat_ior")
        color = _given(self.clearcoat_color, "clearcoat_color")
        model_params = replace(
            params.params,
            clearcoat=self.clearcoat,
            clearcoat_roughness=_given(self.clearcoat_roughness, "clearcoat_roughness"),
            clearcoat_eta=coat_ior / medium,
            clearcoat_color=np.asarray(color, np.float64),
        )
        model = replace(params.model, clearcoat=self.clearcoat_model)
        return replace(params, model=model, params=model_params)

    def resolve_base(self) -> MaterialParams:
        """The material without its clear coat: preset, explicit keys, defaults."""
        base, metallic, f0 = [0.8, 0.8, 0.8], 0.0, 0.04
        p = self._preset()
        ior = getattr(p, "ior", None)
        medium = getattr(p, "medium_ior", 1.0)
        if p is not None:
            metallic = p.metallic
            if metallic > 0.0:
                base = list(p.f0)
            f0 = p.f0_scalar if p.kind == "dielectric" else 0.04
        if self.base_color is not None:
            base = list(self.base_color)
        if self.metallic is not None:
            metallic = self.metallic
        if self.ior is not None:
            ior = self.ior
        if self.medium_ior is not None:
            medium = self.medium_ior
        if self.ior is not None or self.medium_ior is not None:
            if ior is None:  # medium given for a material known by its F0 in air
                ior = float(ior_from_f0(min(f0, 0.99)))
            f0 = float(f0_from_ior(ior, medium))
        if self.f0 is not None:
            f0 = self.f0
        if ior is None:
            ior = float(ior_from_f0(min(f0, 0.99))) * medium  # gives F0 in this medium
        eta_d = ior / medium
        conductor = self._conductor_index()
        if conductor is not None:
            eta, k = conductor
        else:  # the fields' defaults (app/common/material_fields.py)
            eta, k = np.array(FIELDS["eta"].default), np.array(FIELDS["k"].default)
        exponent = (
            FIELDS["fresnel_exponent"].default if self.fresnel_p is None else 1.0 / self.fresnel_p
        )
        film_ior = _given(self.film_ior, "film_ior")
        params = ModelParams(
            f90=np.asarray(_given(self.f90, "f90"), np.float64),
            fresnel_exponent=exponent,
            eta=eta / medium,
            eta_dielectric=eta_d,
            k=k / medium,
            gtr_gamma=_given(self.gtr_gamma, "gtr_gamma"),
            specular_color=np.asarray(_given(self.specular_color, "specular_color"), np.float64),
            # Thin film (RTR4 §9.11): indices relative to the medium, as eta's.
            film_thickness=_given(self.film_thickness, "film_thickness"),
            film_eta=film_ior / medium,
            film_ior=film_ior,
            transmission=_given(self.transmission, "transmission"),
            thickness=_given(self.thickness, "thickness"),
            attenuation_color=np.asarray(
                _given(self.attenuation_color, "attenuation_color"), np.float64
            ),
            attenuation_distance=_given(self.attenuation_distance, "attenuation_distance"),
            dispersion=_given(self.dispersion, "dispersion"),
        )
        if self.diffraction != "none":  # diffraction grating (RTR4 §9.11)
            params = replace(
                params,
                grating_period=_given(self.grating_period, "grating_period"),
                grating_depth=_given(self.grating_depth, "grating_depth"),
            )
        # sheen (RTR4 §9.10): only a non-black colour with a model makes a layer; without
        # one the parameters stay zero, so such materials share a row and a program.
        sheen_on = (
            self.sheen != "none" and self.sheen_color is not None and max(self.sheen_color) > 0
        )
        if sheen_on:
            params = replace(
                params,
                sheen_color=np.asarray(self.sheen_color, np.float64),
                sheen_roughness=_given(self.sheen_roughness, "sheen_roughness"),
            )
        if self.diffuse == "cloth_empirical":  # empirical cloth (RTR4 §9.10)
            rim = _given(self.cloth_rim, "cloth_rim")
            inner = _given(self.cloth_inner, "cloth_inner")
            k_sheen = _given(self.cloth_sheen, "cloth_sheen")
            c_sheen = _given(self.cloth_sheen_color, "cloth_sheen_color")
            params = replace(
                params,
                cloth_rim_inner=np.asarray([*rim, *inner], np.float64),
                cloth_diffuse=_given(self.cloth_diffuse, "cloth_diffuse"),
                cloth_scatter=np.asarray(_given(self.cloth_scatter, "cloth_scatter"), np.float64),
                cloth_wrap=_given(self.cloth_wrap, "cloth_wrap"),
                cloth_sheen=k_sheen * np.asarray(c_sheen, np.float64),
            )
        if self.fiber != "none":  # micro-cylinder fibres (RTR4 §9.10), degrees -> radians
            params = replace(
                params,
                fiber_rotation=math.radians(_given(self.fiber_rotation, "fiber_rotation")),
                fiber_curvature=math.radians(_given(self.fiber_curvature, "fiber_curvature")),
                fiber_gamma_v=math.radians(_given(self.fiber_gamma_v, "fiber_gamma_v")),
                fiber_kd=_given(self.fiber_kd, "fiber_kd"),
            )
        anisotropy = 0.0 if self.anisotropy is None else self.anisotropy
        model = Model(
            fresnel=self.fresnel,
            ndf=self.ndf,
            lambda_form=self.lambda_form,
            g2=self.g2,
            correlation=self.correlation,
            diffuse=self.diffuse,
            multiscatter=self.multiscatter,
            anisotropic=anisotropy != 0.0,
            internal=self.fresnel == "schlick" and eta_d < 1.0,
            # a coloured dielectric F0 (RTR4 §9.5): compiled in only where it is not white
            specular_color=bool(np.any(np.asarray(params.specular_color) != 1.0)),
            thin_film=self.thin_film,  # thin film (RTR4 §9.11)
            sheen=self.sheen if sheen_on else "none",  # sheen
            diffraction=self.diffraction,  # diffraction (RTR4 §9.11)
            fiber=self.fiber,  # micro-cylinder fibres (RTR4 §9.10)
            # the empirical cloth's wrapped cosine (RTR4 §9.10)
            cloth_wrap_form=self.cloth_wrap_form or "filament",
        )
        roughness = 0.5 if self.roughness is None else self.roughness
        return MaterialParams(
            (base[0], base[1], base[2]), metallic, roughness, f0, anisotropy, model, params
        )


class FileMaterial(_Strict):
    """One of a glTF file's own materials with its factors overridden by the scene
    (``objects[i].file_materials."<name>"``, docs/scene-format.md): each key replaces the
    glTF 2.0 factor of the same meaning where the loader reads it (app/scene/gltf.py), so
    the file's maps keep multiplying it (a roughness factor is baked into the file's
    normal/roughness chain as the file's own is). Unset keys keep the file's values."""

    base_color: UnitColor | None = None  # pbrMetallicRoughness.baseColorFactor, RGB
    alpha: Unit | None = None  # baseColorFactor's A
    metallic: Unit | None = None  # metallicFactor
    roughness: Unit | None = None  # roughnessFactor
    emissive: UnitColor | None = None  # emissiveFactor
    # KHR_materials_emissive_strength's emissiveStrength (multiplies emissive)
    emissive_strength: Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)] | None = None

    def pbr(
        self, factor: np.ndarray, metallic: float, roughness: float
    ) -> tuple[np.ndarray, float, float]:
        """The file's baseColorFactor (RGBA), metallicFactor and roughnessFactor with
        this override's keys in their place."""
        factor = np.array(factor, np.float64)
        if self.base_color is not None:
            factor[:3] = self.base_color
        if self.alpha is not None:
            factor[3] = self.alpha
        metallic = metallic if self.metallic is None else float(self.metallic)
        roughness = roughness if self.roughness is None else float(self.roughness)
        return factor, metallic, roughness

    def emission(self, factor: np.ndarray, strength: float) -> tuple[np.ndarray, float]:
        """The file's emissiveFactor and emissiveStrength with this override's in place."""
        if self.emissive is not None:
            factor = np.array(self.emissive, np.float64)
        if self.emissive_strength is not None:
            strength = float(self.emissive_strength)
        return factor, strength


Shape = Literal["sphere", "box", "plane", "cylinder", "capsule", "mesh"]


class SceneObject(_Strict):
    """A trimesh primitive or a mesh file, placed by scale, then rotation, then translation."""

    name: str | None = None
    shape: Shape
    file: str | None = None  # mesh: path relative to the scene file
    material: str | None = None  # name in [materials]; a mesh file may bring its own
    radius: Positive | None = None  # sphere, cylinder, capsule (m)
    height: Positive | None = None  # cylinder, capsule (m)
    size: Annotated[list[Positive], Field(min_length=2, max_length=3)] | None = None  # box, plane
    subdivisions: Annotated[int, Field(strict=True, ge=0, le=6)] | None = None  # sphere
    position: Vec3 = [0.0, 0.0, 0.0]
    rotation: Vec3 = [0.0, 0.0, 0.0]  # degrees about X, then Y, then Z
    scale: Positive | Annotated[list[Positive], Field(min_length=3, max_length=3)] = 1.0
    # A glTF file's KHR_lights_punctual lights, placed by this object (docs/gltf-lights-
    # cameras.md); c_light = light_scale x color x intensity / pi.
    import_lights: Annotated[bool, Field(strict=True)] = False
    light_scale: Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)] | None = None
    # A glTF file's pose (docs/gltf.md, "Animation"): an animation by name or index, a
    # time in seconds (clamped to the animation's range), a KHR_materials_variants name.
    animation: str | Annotated[int, Field(strict=True, ge=0)] | None = None
    time: Annotated[Real, Field(ge=-1e9, le=1e9)] | None = None
    variant: str | None = None
    # A glTF file's own materials by name (or index), their factors overridden
    # (``FileMaterial``; app/scene/file_materials.py names them).
    file_materials: Annotated[dict[str, FileMaterial], Field(max_length=MAX_MATERIALS)] | None = (
        None
    )

    @field_validator("scale", mode="wrap")
    @classmethod
    def _scale(cls, value: object, handler: ValidatorFunctionWrapHandler) -> object:
        # One message instead of one per union member (whose locs name pydantic's types).
        try:
            return handler(value)
        except ValidationError:
            raise ValueError("must be a number > 0 or a list of 3 numbers > 0") from None

    @field_validator("animation", mode="wrap")
    @classmethod
    def _animation(cls, value: object, handler: ValidatorFunctionWrapHandler) -> object:
        try:
            return handler(value)
        except ValidationError:
            raise ValueError("must be an animation's name or its index (an integer >= 0)") from None

    @model_validator(mode="after")
    def _check(self) -> SceneObject:
        allowed = {
            "sphere": {"radius", "subdivisions"},
            "box": {"size"},
            "plane": {"size"},
            "cylinder": {"radius", "height"},
            "capsule": {"radius", "height"},
            "mesh": {"file"},
        }[self.shape]
        for key in ("file", "radius", "height", "size", "subdivisions"):
            if key not in allowed and getattr(self, key) is not None:
                raise ValueError(f"{key}: does not apply to shape '{self.shape}'")
        if self.shape == "mesh" and self.file is None:
            raise ValueError("file: shape 'mesh' needs it")
        gltf = self.file is not None and self.file.lower().endswith((".gltf", ".glb"))
        if self.import_lights and not gltf:
            raise ValueError("import_lights: needs a glTF file (.gltf or .glb) as file")
        for key in ("animation", "time", "variant", "file_materials"):
            if getattr(self, key) is not None and not gltf:
                raise ValueError(f"{key}: needs a glTF file (.gltf or .glb) as file")
        if self.file_materials is not None and self.material is not None:
            raise ValueError(
                "file_materials: edits the file's own materials, which material replaces: "
                "give one of them"
            )
        if self.light_scale is not None and not self.import_lights:
            raise ValueError("light_scale: applies only with import_lights = true")
        if self.shape != "mesh" and self.material is None:
            raise ValueError(f"material: shape '{self.shape}' needs it")
        if self.size is not None:
            want = 2 if self.shape == "plane" else 3
            if len(self.size) != want:
                raise ValueError(f"size: a {self.shape} takes {want} numbers")
        return self


ENVIRONMENT_SOURCES = ("uniform", "image", "sky", "studio")
# Keys that belong to one source only (docs/scene-format.md, docs/ibl.md).
_SOURCE_KEYS = {"radiance": "uniform", "file": "image", "sun_direction": "sky", "turbidity": "sky"}


# ``samples`` left out: a uniform environment's quadrature directions per pixel (docs/ibl.md,
# "The uniform environment": 128 keep a compensated white metal within 1 % of the furnace
# and the models measured there within 2 %), a map's ray-caster cell lights.
UNIFORM_SAMPLES = 128
MAP_SAMPLES = 256


class Environment(_Strict):
    """The radiance arriving from every direction: a uniform ``radiance`` (the white
    furnace, section 3), integrated per pixel by ``samples`` directions of a deterministic
    quadrature, or an equirectangular HDR image ``file``, a Preetham daylight ``sky`` or a
    ``studio`` (app/textures/environment.py), lit by image-based lighting and, in the
    float64 ray-caster, by ``samples`` cell lights (docs/ibl.md)."""

    source: Literal[ENVIRONMENT_SOURCES] = "uniform"  # type: ignore[valid-type]
    radiance: Color = [1.0, 1.0, 1.0]
    samples: Annotated[int, Field(strict=True, ge=16, le=4096)] | None = None
    file: TexturePath | None = None  # .hdr or .exr, relative to the scene file
    sun_direction: Vec3 | None = None  # towards the sun (default [0.5, 0.6, -0.6])
    turbidity: Annotated[Real, Field(ge=2.0, le=10.0)] | None = None  # default 3 (clear)
    rotation: Annotated[Real, Field(ge=-360.0, le=360.0)] = 0.0  # degrees about +Y
    intensity: Annotated[Real, Field(ge=0.0, le=MAX_RADIANCE)] = 1.0
    # true: pixels no surface covers show the environment (the scene's background colour
    # otherwise); image, sky and studio only (app/render/background.py)
    background: Annotated[bool, Field(strict=True)] = False

    @model_validator(mode="after")
    def _check(self) -> Environment:
        # A key counts as given when it differs from its default: the renderer's edits and
        # the comparisons re-validate model_dump(), which writes every key.
        fields = type(self).model_fields
        given = {k for k in self.model_fields_set if getattr(self, k) != fields[k].default}
        for key, source in _SOURCE_KEYS.items():
            if key in given and self.source != source:
                raise ValueError(f'{key}: applies only with source = "{source}"')
        if self.source == "image" and self.file is None:
            raise ValueError('file: source = "image" needs it')
        if self.source == "uniform":
            for key in ("rotation", "intensity", "background"):
                if key in given:
                    raise ValueError(f"{key}: does not apply to a uniform environment")
        if self.samples is None:  # the source's own default (kept out of model_fields_set)
            default = UNIFORM_SAMPLES if self.source == "uniform" else MAP_SAMPLES
            object.__setattr__(self, "samples", default)
        _nonzero(self.sun_direction, "sun_direction")
        if self.sun_direction is not None and self.sun_direction[1] <= 0.0:
            raise ValueError("sun_direction: the sun must be above the horizon (y > 0)")
        return self

    @field_serializer("samples")
    def _samples_as_given(self, samples: int) -> int | None:
        """``samples`` as the file gave it: None where it is the source's own default, so
        that an edit of a dumped environment's ``source`` (the renderer's and the API's
        edits validate ``model_dump()`` again) takes the new source's default."""
        return samples if "samples" in self.model_fields_set else None


class Scene(_Strict):
    """A whole scene file."""

    background: Color = [0.0, 0.0, 0.0]  # linear radiance where no surface is hit
    environment: Environment | None = None
    camera: Camera = Camera()
    render: RenderSettings = RenderSettings()
    materials: Annotated[dict[str, Material], Field(max_length=MAX_MATERIALS)] = {}
    lights: Annotated[list[Light], Field(max_length=MAX_LIGHTS)] = []
    objects: Annotated[list[SceneObject], Field(max_length=MAX_OBJECTS)] = []
