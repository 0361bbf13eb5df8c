"""The material table's row, declared once: every per-material number of the optional BRDF
models (``ModelParams``), where the lighting pass's material table holds it, and what a
scene file and the viewer call it.

One ``MaterialField`` per number says its name (the ``ModelParams`` attribute and the GLSL
struct member), its texel and channels in the row, its default, its valid range and unit,
the model or layer it belongs to, the scene keys it is made from and how the viewer shows
them. From this table app/common/models.py generates ``ModelParams``'s defaults,
``pack_model_params``, ``unpack_model_params``, ``MATERIAL_TEXELS`` and the GLSL struct
``ModelParams`` with its ``fetch_model_params`` (written into every program's header by
app/gl/shaders.py); app/frame/materials.py keys its rows by the same list; the scene schema
(app/scene/model.py) and the viewer's sliders (app/viewer/panels.py) read the defaults,
ranges and labels of the scene keys here. docs/architecture.md, "Adding a material field",
walks through adding one.

Texel 3 of a row holds the model group and the model's codes (app/common/models.py
``MODEL_CODE_FIELDS``), not numbers of this table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

CHANNELS = "rgba"
# Texel 3: (model group, Fresnel code, specular code, diffuse code) (app/common/models.py).
MODEL_CODES_TEXEL = 3


@dataclass(frozen=True)
class Layer:
    """A model or layer whose numbers share texels of the row.

    ``switch`` is the ``Model`` attribute that turns the layer on (on: ``on_value``, or
    where that is None, neither False nor "none"); with ``packed_always`` False the row
    holds its numbers only where it is on (zeros elsewhere), else every row holds them
    (the defaults where the layer is off, so that its formulas stay finite where a pass
    forces it on). ``present``: a (field,
    channel) that is positive in every row written since the layer had its texels, so that
    ``unpack_model_params`` reads a table from before them (zeros) as the defaults."""

    name: str
    rtr4: str  # the section of RTR4 that describes it
    switch: str | None  # Model attribute; None: the core models, always on
    packed_always: bool = True
    present: tuple[str, int] | None = None
    on_value: str | None = None  # the switch's value that turns it on, where not any

    def on(self, model: object) -> bool:
        """Whether ``model`` (a ``Model``) has this layer on."""
        if self.switch is None:
            return True
        value = getattr(model, self.switch)
        if self.on_value is not None:
            return value == self.on_value
        return value not in (False, "none")


LAYERS: dict[str, Layer] = {
    layer.name: layer
    for layer in (
        Layer("core", "§9.5-9.9", None),
        Layer("clearcoat", "§9.12", "clearcoat", present=("clearcoat_eta", 0)),
        Layer("sheen", "§9.10", "sheen"),
        Layer("thin_film", "§9.11", "thin_film", packed_always=False),
        Layer("grating", "§9.11", "diffraction", packed_always=False),
        Layer(
            "cloth", "§9.10", "diffuse", present=("cloth_rim_inner", 1), on_value="cloth_empirical"
        ),
        Layer("fiber", "§9.10", "fiber", present=("fiber_gamma_v", 0)),
    )
}


@dataclass(frozen=True)
class Control:
    """How the viewer's Material panel shows a scene key: a slider (or, for a colour, a
    colour editor) labelled ``label`` over [``low``, ``high``] in the key's unit."""

    label: str
    low: float = 0.0
    high: float = 1.0
    logarithmic: bool = False
    color: bool = False


@dataclass(frozen=True)
class SceneKey:
    """A flat key of a scene's material (app/scene/model.py ``Material``) that a field is
    made from. ``default``: the value the scene gives it where the key is unset and its
    layer is on, in the key's unit; None: the field's own default. ``low``/``high``: the
    range the schema accepts (colours: per channel)."""

    name: str
    low: float
    high: float
    unit: str = ""
    default: float | tuple[float, ...] | None = None
    control: Control | None = None


@dataclass(frozen=True)
class MaterialField:
    """One number (1, 3 or 4 components) of the material row.

    ``default``: its value in ``ModelParams()``, which every material without its layer
    keeps; ``low``/``high``: its valid range (per component), ``unit`` its unit, both in
    the row's terms (indices relative to the medium, angles in radians). ``keys``: the
    scene keys it is made from (empty: derived from others, e.g. eta_dielectric from ior or
    f0 and medium_ior)."""

    name: str
    texel: int
    channels: str  # letters of "rgba", consecutive: "rgb", "a", "rgba", ...
    default: float | tuple[float, ...]
    layer: str  # a key of LAYERS
    low: float
    high: float
    unit: str
    doc: str
    keys: tuple[SceneKey, ...] = ()

    @property
    def size(self) -> int:
        """Its component count: 1 (a float), 3 (a vec3) or 4 (a vec4)."""
        return len(self.channels)

    @property
    def first(self) -> int:
        """The index of its first channel in the texel (r = 0)."""
        return CHANNELS.index(self.channels[0])

    @property
    def glsl_type(self) -> str:
        return {1: "float", 3: "vec3", 4: "vec4"}[self.size]

    @property
    def packed_always(self) -> bool:
        """Whether every row holds it, or only the rows where its layer is on."""
        return LAYERS[self.layer].packed_always


WHITE = (1.0, 1.0, 1.0)
BLACK = (0.0, 0.0, 0.0)


def _keyed(
    name: str,
    texel: int,
    channels: str,
    default: float | tuple[float, ...],
    layer: str,
    low: float,
    high: float,
    unit: str,
    doc: str,
    control: Control | None = None,
    key_default: float | tuple[float, ...] | None = None,
) -> MaterialField:
    """A field made from the one scene key of its own name, range and unit (most fields
    are), so that its row says them once; ``control``: the viewer's, ``key_default``: the
    scene's default where it is not the field's (``SceneKey``)."""
    key = SceneKey(name, low, high, unit, key_default, control)
    return MaterialField(name, texel, channels, default, layer, low, high, unit, doc, (key,))


# The order is ModelParams's (its positional order) and the GLSL struct's. Columns: name,
# texel, channels, default, layer, low, high, unit, meaning, scene keys (``_keyed``: the one
# of the field's own name, range and unit, then its viewer control).
# fmt: off
MATERIAL_FIELDS: tuple[MaterialField, ...] = (
    # --- texels 0-2: the models of RTR4 §9.5-9.9 ---
    _keyed("f90", 0, "rgb", WHITE, "core", 0.0, 1.0, "",
           "generalised Schlick: F at 90 degrees",
           Control("f90", color=True)),
    MaterialField("fresnel_exponent", 0, "a", 5.0, "core", 0.1, 100.0, "",
                  "generalised Schlick: 1/p (the scene gives p)",
                  (SceneKey("fresnel_p", 0.01, 10.0,
                            control=Control("fresnel p (exponent 1/p)", 0.01, 2.0)),)),
    _keyed("eta", 1, "rgb", (1.5, 1.5, 1.5), "core", 0.0, 100.0, "",
           "conductor: n / n1 per channel (eta / medium_ior)"),
    MaterialField("eta_dielectric", 1, "a", 1.5, "core", 0.1, 10.0, "",
                  "dielectric: n2 / n1 (from ior or f0, and medium_ior)"),
    _keyed("k", 2, "rgb", BLACK, "core", 0.0, 100.0, "",
           "conductor: k / n1 per channel (k / medium_ior)"),
    _keyed("gtr_gamma", 2, "a", 2.0, "core", 0.1, 20.0, "",
           "GTR tail exponent (2 = GGX)",
           Control("gtr gamma", 0.1, 20.0)),
    # --- texel 13: the dielectric F0's colour (glTF KHR_materials_specular) ---
    _keyed("specular_color", 13, "rgb", WHITE, "core", 0.0, 1.0, "",
           "the dielectric F0's colour: F0 = f0 specular_color (linear RGB; white: "
           "the G-buffer's one F0 alone)",
           Control("specular colour", color=True)),
    MaterialField("specular_color_map", 13, "a", 0.0, "core", 0.0, 1.0, "",
                  "what G-buffer RT6's RGB scales: 1 specular_color (glTF "
                  "specularColorTexture), 0 sheen_color (sheenColorTexture)"),
    MaterialField("sheen_roughness_map", 5, "b", 0.0, "core", 0.0, 1.0, "",
                  "what G-buffer RT6's A scales: 1 sheen_roughness (glTF "
                  "sheenRoughnessTexture), 0 clearcoat (clearcoatTexture)"),
    # --- texel 7: thin film (RTR4 §9.11), only where Model.thin_film ---
    _keyed("film_thickness", 7, "r", 0.0, "thin_film", 0.0, 5000.0, "nm",
           "the film's thickness; 0 = the base's Fresnel alone",
           Control("film thickness (nm)", 0.0, 1000.0), key_default=400.0),
    MaterialField("film_eta", 7, "g", 1.33, "thin_film", 0.1, 10.0, "",
                  "film index / medium index (n2 / n1: film_ior / medium_ior)"),
    _keyed("film_ior", 7, "b", 1.33, "thin_film", 1.0, 10.0, "",
           "the film's index n2 itself (the optical path 2 n2 d cos(theta2))",
           Control("film index", 1.0, 3.0)),
    MaterialField("film_factor", 7, "a", 1.0, "thin_film", 0.0, 1.0, "",
                  "the film's strength: F = mix(F_base, F_film, film_factor) (glTF "
                  "iridescenceFactor; 1 for a scene file's film)"),
    MaterialField("film_thickness_min", 8, "b", 0.0, "thin_film", 0.0, 5000.0, "nm",
                  "the thickness where a thickness map reads 0 (glTF "
                  "iridescenceThicknessMinimum; film_thickness where it reads 1)"),
    # --- texel 6: sheen (RTR4 §9.10); black = no layer ---
    _keyed("sheen_color", 6, "rgb", BLACK, "sheen", 0.0, 1.0, "",
           "the cloth layer's colour, linear RGB; black: no layer",
           Control("sheen colour", color=True)),
    _keyed("sheen_roughness", 6, "a", 0.0, "sheen", 0.0, 1.0, "",
           "its perceptual roughness (alpha = r^2)",
           Control("sheen roughness", 0.0, 1.0), key_default=0.5),
    # --- texels 4-5: clear coat (RTR4 §9.12), the defaults where a material has none ---
    _keyed("clearcoat", 4, "a", 0.0, "clearcoat", 0.0, 1.0, "",
           "strength 0..1 (0: no coat, and Model.clearcoat is 'none')",
           Control("clear coat", 0.0, 1.0)),
    _keyed("clearcoat_roughness", 5, "r", 0.0, "clearcoat", 0.0, 1.0, "",
           "perceptual; the coat's alpha = r^2 (floored)",
           Control("coat roughness", 0.0, 1.0)),
    MaterialField("clearcoat_eta", 5, "g", 1.5, "clearcoat", 0.1, 10.0, "",
                  "the coat's index / the medium's (clearcoat_ior / medium_ior)",
                  (SceneKey("clearcoat_ior", 1.0, 10.0,
                            control=Control("coat index", 1.0, 3.0)),)),
    _keyed("clearcoat_color", 4, "rgb", WHITE, "clearcoat", 0.0, 1.0, "",
           "transmittance at normal incidence through the coat, once (linear RGB): "
           "T0 = exp(-sigma_a d); along a path at theta_t inside, T0^(1/cos)",
           Control("coat colour", color=True)),
    # --- texel 8: diffraction grating (RTR4 §9.11), only where Model.diffraction ---
    MaterialField("grating_period", 8, "r", 0.0, "grating", 0.0, 20000.0, "nm",
                  "the groove spacing d",
                  (SceneKey("grating_period", 200.0, 20000.0, "nm", 1600.0,
                            Control("groove period (nm)", 200.0, 20000.0, logarithmic=True)),)),
    _keyed("grating_depth", 8, "g", 0.0, "grating", 0.0, 300.0, "nm",
           "the sinusoidal profile's peak-to-valley depth",
           Control("groove depth (nm)", 0.0, 300.0), key_default=120.0),
    # --- texels 9-11: empirical cloth (RTR4 §9.10, diffuse = "cloth_empirical"); the
    # defaults, with no sheen, make the model Lambert exactly ---
    MaterialField("cloth_rim_inner", 9, "rgba", (0.0, 1.0, 0.0, 1.0), "cloth", 0.0, 64.0, "",
                  "(k_rim, a_rim, k_inner, a_inner): cloth_rim, then cloth_inner",
                  (SceneKey("cloth_rim", 0.0, 64.0, "", (0.0, 1.0)),
                   SceneKey("cloth_inner", 0.0, 64.0, "", (0.0, 1.0)))),
    _keyed("cloth_diffuse", 11, "a", 1.0, "cloth", 0.0, 10.0, "", "k_diff",
           Control("k diffuse", 0.0, 10.0)),
    _keyed("cloth_scatter", 10, "rgb", WHITE, "cloth", 0.0, 1.0, "",
           "c_scatter (linear RGB)",
           Control("scatter colour", color=True)),
    _keyed("cloth_wrap", 10, "a", 0.0, "cloth", 0.0, 1.0, "", "w",
           Control("wrap w", 0.0, 1.0)),
    MaterialField("cloth_sheen", 11, "rgb", BLACK, "cloth", 0.0, 10.0, "",
                  "k_sheen c_sheen: cloth_sheen times cloth_sheen_color",
                  (SceneKey("cloth_sheen", 0.0, 10.0, "", 0.0,
                            Control("k sheen", 0.0, 10.0)),
                   SceneKey("cloth_sheen_color", 0.0, 1.0, "", WHITE,
                            Control("sheen colour##cloth", color=True)))),
    # --- texel 12: micro-cylinder fibre (RTR4 §9.10); the scene's angles are degrees ---
    MaterialField("fiber_rotation", 12, "r", 0.0, "fiber", -2.0 * math.pi, 2.0 * math.pi,
                  "rad", "the thread's direction: the tangent turned about n",
                  (SceneKey("fiber_rotation", -360.0, 360.0, "deg", 0.0,
                            Control("thread rotation (deg)", -180.0, 180.0)),)),
    MaterialField("fiber_curvature", 12, "g", 0.0, "fiber", 0.0, math.pi / 3.0, "rad",
                  "the thread's largest tilt out of the surface along its length",
                  (SceneKey("fiber_curvature", 0.0, 60.0, "deg", 0.0,
                            Control("thread curvature (deg)", 0.0, 60.0)),)),
    MaterialField("fiber_gamma_v", 12, "b", math.radians(20.0), "fiber",
                  math.radians(1.0), math.pi / 2.0, "rad", "Sadeghi's volume-scattering width",
                  (SceneKey("fiber_gamma_v", 1.0, 90.0, "deg", 20.0,
                            Control("volume lobe width (deg)", 1.0, 90.0)),)),
    _keyed("fiber_kd", 12, "a", 0.3, "fiber", 0.0, 1.0, "",
           "Sadeghi's isotropic share k_d of the volume scattering",
           Control("isotropic share k_d", 0.0, 1.0)),
    # --- texels 14-15: transmission and volume (RTR4 §14.5; glTF KHR_materials_transmission,
    # KHR_materials_volume): core fields, every row holds them (transmission 0: an opaque
    # surface); the transmission pass (app/render/transmission.py) draws the parts whose
    # row has transmission > 0 ---
    _keyed("attenuation_color", 14, "rgb", WHITE, "core", 0.0, 1.0, "",
           "the colour white light becomes after attenuation_distance inside the "
           "volume (Beer-Lambert, linear RGB)",
           Control("attenuation colour", color=True)),
    _keyed("transmission", 14, "a", 0.0, "core", 0.0, 1.0, "",
           "the share of the dielectric base's light refracted through the surface "
           "instead of diffused (0: opaque, drawn in the G-buffer)",
           Control("transmission", 0.0, 1.0)),
    _keyed("thickness", 15, "r", 0.0, "core", 0.0, 1.0e4, "m",
           "the volume's thickness in object units (0: thin-walled, no refraction "
           "offset); the model matrix scales it",
           Control("thickness (m)", 0.0, 2.0)),
    _keyed("attenuation_distance", 15, "g", 0.0, "core", 0.0, 1.0e6, "m",
           "the distance at which white light becomes attenuation_color (0: no "
           "attenuation, the specification's infinity)",
           Control("attenuation distance (m)", 0.01, 100.0,
                                            logarithmic=True)),
    _keyed("dispersion", 15, "b", 0.0, "core", 0.0, 100.0, "",
           "KHR_materials_dispersion: 20 / V_d (the Abbe number); spreads the index "
           "over the three channels' wavelengths (0: one index)",
           Control("dispersion (20 / Abbe)", 0.0, 1.0)),
)
# fmt: on

FIELDS: dict[str, MaterialField] = {f.name: f for f in MATERIAL_FIELDS}
# Texels per material row: the fields' and the codes' texel (app/common/models.py; the
# GLSL reads the width from the generated MATERIAL_TEXELS).
MATERIAL_TEXELS = 1 + max(MODEL_CODES_TEXEL, *(f.texel for f in MATERIAL_FIELDS))


def _check_table() -> None:
    """Refuse, at import, a table whose fields overlap, leave their texel or name a layer
    that is not declared: one mistake here would move every material's numbers."""
    taken: dict[tuple[int, int], str] = {}
    for f in MATERIAL_FIELDS:
        if f.layer not in LAYERS:
            raise ValueError(f"material field {f.name}: unknown layer {f.layer!r}")
        if f.size not in (1, 3, 4) or f.channels not in CHANNELS:
            raise ValueError(f"material field {f.name}: channels {f.channels!r}")
        size = 1 if isinstance(f.default, float) else len(f.default)
        if size != f.size:
            raise ValueError(f"material field {f.name}: default has {size} components")
        for c in range(f.first, f.first + f.size):
            where = (f.texel, c)
            if f.texel == MODEL_CODES_TEXEL or where in taken:
                other = taken.get(where, "the model codes")
                raise ValueError(f"material field {f.name}: texel {f.texel} taken by {other}")
            taken[where] = f.name
    for layer in LAYERS.values():
        if layer.present is not None and layer.present[0] not in FIELDS:
            raise ValueError(f"layer {layer.name}: unknown field {layer.present[0]}")


_check_table()


@cache
def scene_keys() -> dict[str, SceneKey]:
    """Every scene key a field is made from, by name."""
    return {key.name: key for f in MATERIAL_FIELDS for key in f.keys}


def scene_default(name: str) -> float | tuple[float, ...]:
    """The default of scene key ``name`` (where unset and its layer is on), in its unit:
    its own, or its field's default."""
    for f in MATERIAL_FIELDS:
        for key in f.keys:
            if key.name == name:
                return f.default if key.default is None else key.default
    raise KeyError(name)
