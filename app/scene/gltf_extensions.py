"""glTF 2.0 ``KHR_materials_*`` extensions mapped onto the project's models (docs/gltf.md).

The glTF reader builds a ``MaterialParams`` from a material's core metallic-roughness
values and hands it here with the material's ``extensions`` object (parsed JSON) and its
JSON path; ``material_extensions`` returns the parameters with every extension the project
has a model for applied. Each mapping says whether it is exact (the extension's formula and
the project's BRDF give the same f(l, v); tests/test_gltf_extensions.py evaluates both) or
what it approximates; docs/gltf.md has the table.

* KHR_materials_ior: the dielectric F0 = ((ior - 1)/(ior + 1))^2 (RTR4 §9.5) and the
  exact Fresnel's index; ``ior = 0`` (the specification's specular-glossiness mode, an
  infinite index whose Fresnel is 1 at every angle) becomes F0 = 1 (Schlick then gives 1
  exactly) with the index ``IOR_ZERO_ETA``.
* KHR_materials_specular: F0 = min(F0_ior specularColor, 1) specular and F90 = specular,
  through the generalised Schlick (RTR4 §9.5); a coloured F0 is its largest channel (the
  G-buffer's F0) times the material row's ``specular_color``, exact; specularTexture's A
  multiplies F0 per pixel (the F0 map), specularColorTexture the colour (G-buffer RT6).
* KHR_materials_anisotropy: alpha_t = mix(alpha, 1, strength^2), alpha_b = alpha, written
  exactly in the project's (roughness, anisotropy) (RTR4 §9.8); the rotation (any angle)
  and the texture's direction (RG) turn the tangent the G-buffer pass writes.
* KHR_materials_sheen: the Charlie sheen with Estevez & Kulla's Smith Lambda and the same
  albedo scaling (RTR4 §9.10).
* KHR_materials_clearcoat: the project's Filament clear coat at the coat index 1.5 (RTR4
  §9.12); approximated (docs/gltf.md lists the differences).
* KHR_materials_iridescence: Belcour & Barla 2017's thin film at the maximum thickness
  (RTR4 §9.11); approximated (the project's film has no strength and uses exact Fresnel).
* KHR_materials_transmission and KHR_materials_volume (RTR4 §14.5): the material row's
  transmission, thickness and Beer-Lambert attenuation, drawn by the screen-space
  transmission pass (app/render/transmission.py); approximated (docs/transmission.md
  measures it against the ray-caster's exact refraction); KHR_materials_dispersion spreads
  its index over the three channels.

Textures: ``map_material_extensions`` also returns the textures the project samples
(``maps``: the clear coat's normal map, the specular F0, the anisotropy strength and
direction, and the extension maps declared in app/common/extension_maps.py, each read
with its declared texture key and channel by ``_declared``: the sheen colour and
roughness, the specular colour and the coat strength (G-buffer RT6), the coat roughness
and the film's strength and thickness (RT8), the transmission and the volume's thickness
(the transmission pass)) and a note for each texture or parameter it cannot honour, for
the reader to attach and report.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from app.common.extension_maps import EXTENSION_MAP, selectors, slots
from app.common.ior import f0_from_ior
from app.common.models import MaterialParams
from app.scene.gltf_document import GltfError

# KHR_materials_ior's ior = 0: "the effective IOR becomes positive infinity and the Fresnel
# term MUST evaluate to 1.0". F0 = 1 makes Schlick exactly 1; the exact dielectric Fresnel
# and the thin film read this finite stand-in, whose F0 is 1 - 4e-6 (float32 keeps it).
IOR_ZERO_ETA = 1e6
# The thickest film the project's thin film takes (the scene format's film_thickness limit;
# docs/thin-film.md measures its series up to there).
MAX_FILM_THICKNESS_NM = 5000.0

SUPPORTED = (
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_anisotropy",
    "KHR_materials_sheen",
    "KHR_materials_clearcoat",
    "KHR_materials_iridescence",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_dispersion",
)
# The extensions' textures the project cannot sample, and what is used instead (each one a
# material names gives a note; docs/gltf.md lists them). Those it samples are declared in
# app/common/extension_maps.py (EXTENSION_MAPS) and read by ``_declared``.
UNSUPPORTED_TEXTURES: dict[str, dict[str, str]] = {}
# Material extensions another part of the reader maps (the emissive strength joins the
# core material's emissive factor).
HANDLED_ELSEWHERE = ("KHR_materials_emissive_strength",)


@dataclass(frozen=True)
class ExtensionTexture:
    """A texture of an extension that the project can sample: the glTF ``textureInfo``
    (or ``normalTextureInfo``) object as parsed JSON, the channel(s) that hold the value,
    and the JSON path it came from (for the reader's errors)."""

    info: Mapping[str, Any]
    channel: str  # "r", "g", "b", "a", "rg" or "rgb"
    key: str


@dataclass(frozen=True)
class ExtensionMapping:
    """What ``map_material_extensions`` made of a material's extensions.

    ``maps``: SurfaceLayer map keys ("coat_normal", "clearcoat", "sheen_color",
    "anisotropy", "anisotropy_direction") to the textures that fill them. ``notes``: one
    line per texture, parameter or extension that is approximated or left out (the reader
    reports them; docs/gltf.md explains each). ``applied``: the extension names that
    changed the parameters.
    """

    params: MaterialParams
    maps: dict[str, ExtensionTexture] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    applied: tuple[str, ...] = ()
    # KHR_materials_anisotropy's anisotropyRotation in radians, in [-pi, pi]: the layer's
    # SurfaceLayer.anisotropy_rotation
    anisotropy_rotation: float = 0.0


def material_extensions(extensions: dict, params: MaterialParams, key: str) -> MaterialParams:
    """``params`` (a glTF material's core values) with its ``KHR_materials_*`` extensions
    applied; ``key`` is the material's JSON path ("materials[2]") for errors. Bad values
    raise ``GltfError(key + ".extensions.KHR_....name", message)``."""
    return map_material_extensions(extensions, params, key).params


def map_material_extensions(
    extensions: Mapping[str, Any] | None, params: MaterialParams, key: str
) -> ExtensionMapping:
    """``material_extensions`` with the textures to attach and the notes on what is
    approximated or unsupported (``ExtensionMapping``)."""
    if extensions is None:
        return ExtensionMapping(params)
    if not isinstance(extensions, Mapping):
        raise GltfError(f"{key}.extensions", "must be a JSON object")
    state = _State(params, key)
    # The specification's layering order: the dielectric's F0 (ior, specular), its lobe
    # (anisotropy), the film on it (iridescence), then sheen, then the coat on top.
    _ior_and_specular(state, extensions)
    layers = (
        ("KHR_materials_transmission", _transmission),
        ("KHR_materials_volume", _volume),
        ("KHR_materials_dispersion", _dispersion),
        ("KHR_materials_anisotropy", _anisotropy),
        ("KHR_materials_iridescence", _iridescence),
        ("KHR_materials_sheen", _sheen),
        ("KHR_materials_clearcoat", _clearcoat),
    )
    for name, apply in layers:
        ext = _extension(state, extensions, name)
        if ext is not None:
            apply(state, ext, name)
    for name in sorted(extensions):
        if name.startswith("KHR_materials_") and name not in SUPPORTED + HANDLED_ELSEWHERE:
            state.notes.append(f"{name}: not supported; the material renders without it")
    flags = selectors(state.maps)  # which map fills a slot two maps share (the row's flags)
    if flags:
        p = state.params
        state.params = replace(p, params=replace(p.params, **flags))
    return ExtensionMapping(
        state.params, state.maps, tuple(state.notes), tuple(state.applied),
        state.anisotropy_rotation,
    )  # fmt: skip


@dataclass
class _State:
    """The parameters as the extensions change them, and what the mapping reports."""

    params: MaterialParams
    key: str
    maps: dict[str, ExtensionTexture] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    applied: list[str] = field(default_factory=list)
    anisotropy_rotation: float = 0.0

    def path(self, name: str, prop: str | None = None) -> str:
        base = f"{self.key}.extensions.{name}"
        return base if prop is None else f"{base}.{prop}"


def _object(state: _State, extensions: Mapping[str, Any], name: str) -> Mapping[str, Any] | None:
    ext = extensions.get(name)
    if ext is None:
        return None
    if not isinstance(ext, Mapping):
        raise GltfError(state.path(name), "must be a JSON object")
    return ext


def _finite(value: object) -> bool:
    """A JSON number (not a boolean) that is finite as a float64 (an integer too large for
    one, which JSON allows, is not)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _number(
    state: _State,
    ext: Mapping[str, Any],
    name: str,
    prop: str,
    default: float,
    lo: float = -math.inf,
    hi: float = math.inf,
) -> float:
    """A finite number in [lo, hi] (JSON booleans are not numbers)."""
    value = ext.get(prop, default)
    if not _finite(value):
        raise GltfError(state.path(name, prop), f"must be a finite number, not {value!r:.40}")
    if not lo <= value <= hi:
        raise GltfError(state.path(name, prop), f"{value!r} is outside [{lo:g}, {hi:g}]")
    return float(value)


def _color(
    state: _State,
    ext: Mapping[str, Any],
    name: str,
    prop: str,
    default: tuple[float, float, float],
    hi: float,
) -> np.ndarray:
    """Three finite numbers in [0, hi] (linear RGB)."""
    value = ext.get(prop, list(default))
    if not isinstance(value, list | tuple) or len(value) != 3 or not all(map(_finite, value)):
        raise GltfError(state.path(name, prop), f"must be 3 finite numbers, not {value!r:.60}")
    if not all(0.0 <= x <= hi for x in value):
        raise GltfError(state.path(name, prop), f"{list(value)!r} is outside [0, {hi:g}]")
    return np.asarray(value, np.float64)


def _texture(
    state: _State, ext: Mapping[str, Any], name: str, prop: str
) -> ExtensionTexture | None:
    """A textureInfo object (its ``index`` a non-negative integer; the reader checks that
    the texture exists), or None where the property is absent."""
    info = ext.get(prop)
    if info is None:
        return None
    index = info.get("index") if isinstance(info, Mapping) else None
    if isinstance(index, bool) or not isinstance(index, int) or index < 0:
        raise GltfError(
            state.path(name, prop), "must be a textureInfo with a non-negative integer index"
        )
    return ExtensionTexture(info, "rgb", state.path(name, prop))


def _declared(state: _State, ext: Mapping[str, Any], key: str) -> ExtensionTexture | None:
    """The texture of extension map ``key`` (app/common/extension_maps.py EXTENSION_MAPS:
    its extension, texture property and channels), or None where the material names none."""
    decl = EXTENSION_MAP[key]
    texture = _texture(state, ext, decl.extension, decl.texture)
    return None if texture is None else replace(texture, channel=decl.channels)


def _attach(state: _State, key: str, texture: ExtensionTexture, instead: str) -> None:
    """Extension map ``key`` sampled from ``texture``, unless a map already attached fills
    the same factor slot (one value per pixel): then a note, and ``instead`` is used."""
    decl = EXTENSION_MAP[key]
    for other in slots(decl.target)[decl.slot]:
        if other.key in state.maps:
            state.notes.append(f"{texture.key}: not supported beside a {other.texture}; {instead}")
            return
    state.maps[key] = texture


def _extension(state: _State, extensions: Mapping[str, Any], name: str) -> Mapping[str, Any] | None:
    """The extension's object (None where the material has none), with a note for each
    texture it names that the project cannot sample (UNSUPPORTED_TEXTURES)."""
    ext = _object(state, extensions, name)
    for prop, instead in UNSUPPORTED_TEXTURES.get(name, {}).items():
        if ext is not None and _texture(state, ext, name, prop) is not None:
            state.notes.append(f"{state.path(name, prop)}: not supported; {instead}")
    return ext


def _apply(
    state: _State, name: str, model: dict[str, Any], params: dict[str, Any], **material: Any
) -> None:
    """Replace fields of the Model, the ModelParams and the MaterialParams itself, and
    record the extension as applied."""
    p = state.params
    state.params = replace(
        p, model=replace(p.model, **model), params=replace(p.params, **params), **material
    )
    state.applied.append(name)


# --- KHR_materials_ior and KHR_materials_specular: the dielectric's Fresnel (RTR4 §9.5) ---


def _ior_and_specular(state: _State, extensions: Mapping[str, Any]) -> None:
    ior_ext = _object(state, extensions, "KHR_materials_ior")
    spec_ext = _extension(state, extensions, "KHR_materials_specular")
    p = state.params
    f0_ior = p.f0  # the core material's F0 (0.04: glTF's fixed ior 1.5)
    eta = p.params.eta_dielectric
    if ior_ext is not None:
        name = "KHR_materials_ior"
        ior = _number(state, ior_ext, name, "ior", 1.5, lo=0.0)
        if 0.0 < ior < 1.0:
            raise GltfError(state.path(name, "ior"), f"{ior!r} must be 0 or at least 1")
        # The specification's outside_ior is 1 (air): F0 = ((ior - 1)/(ior + 1))^2.
        f0_ior, eta = (1.0, IOR_ZERO_ETA) if ior == 0.0 else (float(f0_from_ior(ior)), ior)
        state.applied.append(name)
    f0, f90 = f0_ior, 1.0
    specular_color = np.ones(3)
    if spec_ext is not None:
        name = "KHR_materials_specular"
        weight = _number(state, spec_ext, name, "specularFactor", 1.0, 0.0, 1.0)
        color = _color(state, spec_ext, name, "specularColorFactor", (1.0, 1.0, 1.0), math.inf)
        # dielectric_f0 = min(F0_ior specularColor, 1) specular; dielectric_f90 = specular.
        f0_rgb = np.minimum(f0_ior * color, 1.0) * weight
        # The G-buffer's one F0 is the largest channel, the material row's specular_color
        # the colour it is scaled by (its largest channel 1): f0 specular_color = f0_rgb.
        f0 = float(f0_rgb.max())
        if f0 > 0.0 and not np.all(f0_rgb == f0):
            specular_color = f0_rgb / f0
        f90 = weight
        colour = _declared(state, spec_ext, "specular_color")
        if colour is not None:  # sRGB RGB: multiplies specular_color per pixel (RT6)
            state.maps["specular_color"] = colour
        texture = _texture(state, spec_ext, name, "specularTexture")
        if texture is not None:  # A: multiplies the dielectric F0 per pixel (the f0 map)
            state.maps["f0"] = replace(texture, channel="a")
            state.notes.append(
                f"{texture.key}: multiplies F0 per pixel; F90 stays specularFactor "
                f"{weight!r} (the project's F90 is one per material)"
            )
        state.applied.append(name)
    if ior_ext is None and spec_ext is None:
        return
    textured = "specular_color" in state.maps
    tinted = textured or bool(np.any(specular_color != 1.0))
    model = replace(p.model, specular_color=tinted) if tinted else p.model
    params = replace(p.params, eta_dielectric=eta, specular_color=specular_color)
    if f90 != 1.0:
        if model.fresnel == "schlick" and not model.internal:
            # Generalised Schlick (RTR4 §9.5), exponent 5: F = F0 + (F90 - F0)(1 - l.h)^5 with
            # F0 = mix(f0, base, m) and F90 = mix(specular, 1, m), which is glTF's
            # mix(dielectric_fresnel, metal_fresnel, metallic) exactly for this metallic.
            m = p.metallic
            f90_rgb = np.full(3, f90 * (1.0 - m) + m)
            model = replace(model, fresnel="schlick_generalized")
            params = replace(params, f90=f90_rgb, fresnel_exponent=5.0)
        else:
            state.notes.append(
                f"{state.path('KHR_materials_specular', 'specularFactor')}: the F90 scale is "
                f"not applied under the '{model.fresnel}' Fresnel model"
            )
    state.params = replace(p, f0=f0, model=model, params=params)


# --- KHR_materials_transmission and KHR_materials_volume (RTR4 §14.5) ---


def _transmission(state: _State, ext: Mapping[str, Any], name: str) -> None:
    factor = _number(state, ext, name, "transmissionFactor", 0.0, 0.0, 1.0)
    texture = _declared(state, ext, "transmission")
    if texture is not None and factor == 0.0:
        state.notes.append(
            f"{texture.key}: transmissionFactor is 0, so the texture changes nothing; "
            "it is not read"
        )
    elif texture is not None:  # R: multiplies the factor per pixel (the transmission pass)
        state.maps["transmission"] = texture
    _apply(state, name, {}, {"transmission": factor})


def _volume(state: _State, ext: Mapping[str, Any], name: str) -> None:
    thickness = _number(state, ext, name, "thicknessFactor", 0.0, 0.0, 1.0e4)
    # attenuationDistance: > 0, default +infinity (no attenuation), the row's 0
    distance = ext.get("attenuationDistance")
    if distance is not None:
        distance = _number(state, ext, name, "attenuationDistance", 1.0, 0.0, math.inf)
        if distance <= 0.0:
            raise GltfError(state.path(name, "attenuationDistance"), "must be positive")
        distance = min(distance, 1.0e6)  # the row's range; past it, no visible attenuation
    color = _color(state, ext, name, "attenuationColor", (1.0, 1.0, 1.0), 1.0)
    texture = _declared(state, ext, "thickness")
    if texture is not None and (thickness == 0.0 or state.params.params.transmission == 0.0):
        state.notes.append(
            f"{texture.key}: the volume is thin-walled or does not transmit, so the "
            "texture changes nothing; it is not read"
        )
    elif texture is not None:  # G: multiplies thicknessFactor per pixel (the same pass)
        state.maps["thickness"] = texture
    volume = {
        "thickness": thickness, "attenuation_color": color,
        "attenuation_distance": 0.0 if distance is None else distance,
    }  # fmt: skip
    _apply(state, name, {}, volume)


def _dispersion(state: _State, ext: Mapping[str, Any], name: str) -> None:
    # 20 / V_d; the project's row holds up to 100 (an Abbe number of 0.2)
    dispersion = _number(state, ext, name, "dispersion", 0.0, 0.0, 100.0)
    _apply(state, name, {}, {"dispersion": dispersion})


# --- KHR_materials_anisotropy (RTR4 §9.8) ---


def _anisotropy(state: _State, ext: Mapping[str, Any], name: str) -> None:
    strength = _number(state, ext, name, "anisotropyStrength", 0.0, 0.0, 1.0)
    rotation = _number(state, ext, name, "anisotropyRotation", 0.0)
    texture = _texture(state, ext, name, "anisotropyTexture")
    if strength == 0.0:  # no anisotropy for the texture to multiply or turn
        if texture is not None:
            state.notes.append(
                f"{texture.key}: anisotropyStrength is 0, so the texture changes nothing; "
                "it is not read"
            )
        return
    p = state.params
    # The extension: alpha_t = mix(alpha, 1, strength^2) along the tangent, alpha_b = alpha.
    # The project (Burley 2012): alpha_x = alpha' (1 + a), alpha_y = alpha' (1 - a) with
    # alpha' = r'^2, so alpha' = (alpha_t + alpha_b)/2 and a = (alpha_t - alpha_b)/(alpha_t +
    # alpha_b) give the same two widths, the same D and the same anisotropic Smith G2.
    alpha = p.roughness * p.roughness
    alpha_t = alpha + (1.0 - alpha) * strength * strength
    alpha_mean = 0.5 * (alpha_t + alpha)
    anisotropy = (alpha_t - alpha) / (alpha_t + alpha)
    # The rotation turns the stretched direction from t towards b: the layer's
    # anisotropy_rotation, any angle, which the G-buffer pass applies to the tangent it
    # writes (glsl/material/layers.glsl). Reduced to [-pi, pi] (exactly: IEEE remainder).
    state.anisotropy_rotation = math.remainder(rotation, 2.0 * math.pi)
    if texture is not None:
        # RG: the direction in (t, b) before the rotation, exact; B: the strength.
        state.maps["anisotropy_direction"] = replace(texture, channel="rg")
        state.maps["anisotropy"] = replace(texture, channel="b")
        state.notes.append(
            f"{texture.key}: its strength (B) multiplies the project's anisotropy linearly "
            "(the extension's alpha_t is quadratic in it)"
        )
    _apply(
        state, name, {"anisotropic": True}, {},
        roughness=math.sqrt(alpha_mean), anisotropy=anisotropy,
    )  # fmt: skip


# --- KHR_materials_iridescence (RTR4 §9.11) ---


def _iridescence(state: _State, ext: Mapping[str, Any], name: str) -> None:
    factor = _number(state, ext, name, "iridescenceFactor", 0.0, 0.0, 1.0)
    film_ior = _number(state, ext, name, "iridescenceIor", 1.3, lo=1.0)
    thinnest = _number(
        state, ext, name, "iridescenceThicknessMinimum", 100.0, 0.0, MAX_FILM_THICKNESS_NM
    )
    thickness = _number(
        state, ext, name, "iridescenceThicknessMaximum", 400.0, 0.0, MAX_FILM_THICKNESS_NM
    )
    strength = _declared(state, ext, "film_factor")
    thick = _declared(state, ext, "film_thickness")
    if factor == 0.0:
        return
    if strength is not None:  # R: multiplies iridescenceFactor per pixel (G-buffer RT8)
        state.maps["film_factor"] = strength
    if thick is not None:  # G: the thickness mix(minimum, maximum, G) per pixel (RT8)
        state.maps["film_thickness"] = thick
    # Without the thickness texture the film is iridescenceThicknessMaximum thick (RT8's B
    # reads 1); the outside medium is air (the specification's outside_ior 1), so film_eta
    # = film_ior. The factor mixes the film's Fresnel with the base's.
    film = {
        "film_thickness": thickness, "film_thickness_min": thinnest, "film_factor": factor,
        "film_ior": film_ior, "film_eta": film_ior,
    }  # fmt: skip
    _apply(state, name, {"thin_film": True}, film)


# --- KHR_materials_sheen (RTR4 §9.10) ---


def _sheen(state: _State, ext: Mapping[str, Any], name: str) -> None:
    color = _color(state, ext, name, "sheenColorFactor", (0.0, 0.0, 0.0), 1.0)
    roughness = _number(state, ext, name, "sheenRoughnessFactor", 0.0, 0.0, 1.0)
    texture = _declared(state, ext, "sheen_color")
    if float(color.max()) == 0.0:  # "If sheenColorFactor is zero, the whole sheen layer
        return  # is disabled": no layer, compiled out, as a scene file's black sheen_color
    if texture is not None:  # RGB, sRGB: multiplies the factor per pixel (G-buffer RT6),
        # where the specular colour's texture does not fill RT6's RGB already
        _attach(state, "sheen_color", texture, "sheenColorFactor alone is used")
    rough = _declared(state, ext, "sheen_roughness")
    if rough is not None:  # A: multiplies the roughness factor per pixel (RT6's A)
        state.maps["sheen_roughness"] = rough
    # The specification's Charlie NDF with Estevez & Kulla's Smith visibility, and its
    # albedo scaling 1 - max(sheenColor) max(E(n.l), E(n.v)): the project's charlie_smith.
    sheen = {"sheen_color": color, "sheen_roughness": roughness}
    _apply(state, name, {"sheen": "charlie_smith"}, sheen)


# --- KHR_materials_clearcoat (RTR4 §9.12) ---

CLEARCOAT_IOR = 1.5  # the extension's fixed coat index (F0 = 0.04)


def _clearcoat(state: _State, ext: Mapping[str, Any], name: str) -> None:
    strength = _number(state, ext, name, "clearcoatFactor", 0.0, 0.0, 1.0)
    roughness = _number(state, ext, name, "clearcoatRoughnessFactor", 0.0, 0.0, 1.0)
    normal = _texture(state, ext, name, "clearcoatNormalTexture")
    if normal is not None:  # its scale, read by the reader with the map: a finite number
        _number(state, normal.info, f"{name}.clearcoatNormalTexture", "scale", 1.0)
    if strength == 0.0:  # "If clearcoatFactor is zero, the whole clearcoat layer is disabled"
        if normal is not None:
            state.notes.append(
                f"{normal.key}: clearcoatFactor is 0, so there is no coat for the texture "
                "to bend; it is not read"
            )
        return
    if normal is not None:
        state.maps["coat_normal"] = normal
    texture = _declared(state, ext, "clearcoat")
    if texture is not None:  # R: multiplies the strength per pixel (G-buffer RT6's A),
        # where the sheen roughness's texture does not fill it already
        _attach(state, "clearcoat", texture, "clearcoatFactor alone is used")
    rough = _declared(state, ext, "clearcoat_roughness")
    if rough is not None:  # G: multiplies the roughness factor per pixel (G-buffer RT8)
        state.maps["clearcoat_roughness"] = rough
    # The medium is air (glTF has no other), so the coat's eta is its index.
    coat = {
        "clearcoat": strength,
        "clearcoat_roughness": roughness,
        "clearcoat_eta": CLEARCOAT_IOR,
        "clearcoat_color": np.ones(3),
    }
    _apply(state, name, {"clearcoat": "filament"}, coat)
