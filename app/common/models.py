"""Which model each term of the BRDF uses, and its parameters.

A ``Model`` is the choice of Fresnel, NDF, Smith Lambda, G2, diffuse and multiple-scattering
terms; the renderer compiles one shader permutation per distinct ``Model`` (its
``defines()``), so a scene pays only for the models it uses. Each choice is declared once
in ``MODEL_CODE_FIELDS`` (its define and its bits in the row's model codes).
``ModelParams`` holds the numbers those models need beyond the G-buffer's
metallic-roughness values; the lighting pass reads them from a per-material table
(``pack_model_params``), whose row is declared once in app/common/material_fields.py.
Both declarations generate the Python and the GLSL side (``material_glsl``, written into
every program's header by app/gl/shaders.py), so neither is written twice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import cache
from typing import Any

import numpy as np

from app.common.material_fields import (
    FIELDS,
    LAYERS,
    MATERIAL_FIELDS,
    MATERIAL_TEXELS,
    MODEL_CODES_TEXEL,
    Layer,
)

# The names a scene file uses, in the order of the GLSL constants (index = value).
FRESNEL_MODELS = ("schlick", "schlick_generalized", "dielectric", "conductor")
NDF_MODELS = ("ggx", "beckmann", "blinn_phong", "gtr")
LAMBDA_FORMS = ("exact", "rational")
G2_MODELS = (
    "separable",
    "height_correlated",
    "direction_correlated",
    "height_direction_correlated",
    "hammon",
)
CORRELATIONS = ("exp", "rational")
DIFFUSE_MODELS = (
    "lambert",
    "shirley",
    "ashikhmin_shirley",
    "burley",
    "oren_nayar",
    "hammon",
    "none",
    "burley_renormalized",
    "cloth_empirical",  # RTR4 §9.10: the empirical cloth terms (app/reference/cloth.py)
)
# --- wrap lighting of the empirical cloth (RTR4 §9.10): the cosine that replaces (n.l)+.
# "filament": Filament's Fd_Wrap, (n.l + w)+ / (1 + w)^2, which conserves energy over the
# sphere; "rtr4": the book's (and the curriculum's) clamp(n.l + w, 0, 1) / (1 + w), which
# reflects (1 + 2w)/(1 + w) of Lambert's in a white furnace (app/reference/cloth.py).
CLOTH_WRAP_FORMS = ("filament", "rtr4")
# --- sheen (RTR4 §9.10): the cloth layer's NDF; "none" (code 0) compiles the layer out ---
# "charlie" and "ashikhmin" take Neubelt's visibility; "charlie_smith" is Charlie's NDF with
# Estevez & Kulla 2017's fitted Smith Lambda (appended: the older codes keep their values;
# code 3 is the last the specular code's two sheen bits hold).
SHEEN_MODELS = ("none", "charlie", "ashikhmin", "charlie_smith")
# --- clear coat (RTR4 §9.12) ---
# A transparent layer over any base model: none (compiled out), Filament's / glTF
# KHR_materials_clearcoat's cheap composition, Weidlich & Wilkie 2007's refracted one.
# "weidlich_wilkie_series": Weidlich & Wilkie's with the coat-base inter-reflection series
# (docs/layered.md), an option beside the plain one, whose figures it would change.
CLEARCOAT_MODELS = ("none", "filament", "weidlich_wilkie", "weidlich_wilkie_series")
# --- diffraction (RTR4 §9.11): a periodic grating's orders over the specular lobe ---
DIFFRACTION_MODELS = ("none", "grating")
# --- micro-cylinder fibres (RTR4 §9.10): a thread along the tangent replaces the base's
# specular and diffuse terms; Kajiya & Kay 1989 or Sadeghi et al. 2013 (app/reference/fiber.py)
FIBER_MODELS = ("none", "kajiya_kay", "sadeghi")

# RTR4 §9.1: which reflections brdf_eval returns, a bitmask (``render.terms``).
TERM_SPECULAR = 1  # surface reflection: f_spec (and the multiple-scattering lobe)
TERM_DIFFUSE = 2  # subsurface reflection: f_diffuse
BRDF_TERMS = {"all": TERM_SPECULAR | TERM_DIFFUSE, "specular": TERM_SPECULAR,
              "diffuse": TERM_DIFFUSE}  # fmt: skip


@dataclass(frozen=True)
class CodeField:
    """One choice of a ``Model``, declared once: its attribute ``attr``, the preprocessor
    name ``define`` that selects it in a specialized pass (glsl/brdf/model.glsl), and its
    bits in the row's model codes (texel 3, read by the uber lighting shader's
    ``fetch_model_codes``): the code ``channel`` ("g" Fresnel, "b" specular, "a" diffuse),
    ``shift`` and ``width``. ``names``: the scene's names in the order of their codes
    (their GLSL constants are ``prefix``_NAME); None for a flag (0 or 1)."""

    attr: str
    define: str
    channel: str
    shift: int
    width: int
    names: tuple[str, ...] | None = None
    prefix: str | None = None  # of the GLSL constants of ``names``: FRESNEL_SCHLICK, ...

    def code(self, value: str | bool) -> int:
        """The code of ``value`` (a name of ``names``, or a flag)."""
        return self.names.index(value) if self.names is not None else int(value)  # type: ignore[arg-type]

    def value(self, code: int) -> str | bool:
        """Inverse of ``code``, from the code channel's integer."""
        bits = (code >> self.shift) & ((1 << self.width) - 1)
        return self.names[bits] if self.names is not None else bool(bits)


# The order of Model.defines(). Fresnel code (.g): fresnel | internal << 2
# | specular_color << 3; specular code
# (.b): ndf | lambda_form << 2 | g2 << 3 | correlation << 6 | anisotropic << 7
# | multiscatter << 8 | sheen << 9 | clearcoat << 11 | thin_film << 13 | diffraction << 14
# | fiber << 16; diffuse code (.a): diffuse | cloth_wrap_form << 4. Small integers, exact
# in float32.
MODEL_CODE_FIELDS: tuple[CodeField, ...] = (
    CodeField("fresnel", "FRESNEL_MODEL", "g", 0, 2, FRESNEL_MODELS, "FRESNEL"),
    CodeField("ndf", "NDF_MODEL", "b", 0, 2, NDF_MODELS, "NDF"),
    CodeField("lambda_form", "LAMBDA_FORM", "b", 2, 1, LAMBDA_FORMS, "LAMBDA"),
    CodeField("g2", "G2_MODEL", "b", 3, 3, G2_MODELS, "G2"),
    CodeField("correlation", "CORRELATION", "b", 6, 1, CORRELATIONS, "CORRELATION"),
    CodeField("diffuse", "DIFFUSE_MODEL", "a", 0, 4, DIFFUSE_MODELS, "DIFFUSE"),
    CodeField("multiscatter", "MULTISCATTER", "b", 8, 1),
    CodeField("anisotropic", "ANISOTROPIC", "b", 7, 1),
    CodeField("internal", "FRESNEL_INTERNAL", "g", 2, 1),  # Schlick at the transmitted angle
    CodeField("specular_color", "SPECULAR_COLOR", "g", 3, 1),  # F0 times specular_color
    CodeField("thin_film", "THIN_FILM", "b", 13, 1),  # thin film (RTR4 §9.11)
    CodeField("sheen", "SHEEN_MODEL", "b", 9, 2, SHEEN_MODELS, "SHEEN"),  # RTR4 §9.10
    CodeField("clearcoat", "CLEARCOAT_MODEL", "b", 11, 2, CLEARCOAT_MODELS, "CLEARCOAT"),
    CodeField("diffraction", "DIFFRACTION_MODEL", "b", 14, 2, DIFFRACTION_MODELS,
              "DIFFRACTION"),  # diffraction grating (RTR4 §9.11)
    CodeField("fiber", "FIBER_MODEL", "b", 16, 2, FIBER_MODELS, "FIBER"),  # fibres, §9.10
    CodeField("cloth_wrap_form", "CLOTH_WRAP_FORM", "a", 4, 1, CLOTH_WRAP_FORMS,
              "CLOTH_WRAP"),  # the empirical cloth's wrapped cosine (RTR4 §9.10)
)  # fmt: skip
_CODE_CHANNELS = ("g", "b", "a")  # (Fresnel, specular, diffuse) of texel 3


def _check_codes() -> None:
    """Refuse, at import, codes whose bits overlap or whose names do not fit their width."""
    taken: dict[tuple[str, int], str] = {}
    for c in MODEL_CODE_FIELDS:
        if c.channel not in _CODE_CHANNELS:
            raise ValueError(f"model code {c.attr}: channel {c.channel!r}")
        if c.names is not None and len(c.names) > 1 << c.width:
            raise ValueError(f"model code {c.attr}: {len(c.names)} names in {c.width} bits")
        for bit in range(c.shift, c.shift + c.width):
            if (c.channel, bit) in taken:
                raise ValueError(f"model code {c.attr}: bit {bit} taken by {taken[c.channel, bit]}")
            taken[c.channel, bit] = c.attr


_check_codes()

# The GLSL name prefix of each term's model constants: FRESNEL_SCHLICK, NDF_GGX, ...
_GLSL_PREFIXES = tuple((c.prefix, c.names) for c in MODEL_CODE_FIELDS if c.names is not None)


def glsl_constants() -> dict[str, int]:
    """The model constants of glsl/brdf/model.glsl (``FRESNEL_SCHLICK 0``, ...) and the
    ``TERM_*`` bits, generated from the names above so that they are written once."""
    out = {
        f"{prefix}_{name.upper()}": code
        for prefix, names in _GLSL_PREFIXES
        for code, name in enumerate(names)
    }
    out.update(TERM_SPECULAR=TERM_SPECULAR, TERM_DIFFUSE=TERM_DIFFUSE)
    out["MATERIAL_TEXELS"] = MATERIAL_TEXELS
    out["SURFACE_TEXEL"] = SURFACE_TEXEL
    return out


@dataclass(frozen=True)
class Model:
    """One choice per BRDF term; the defaults are the renderer's standard model
    (Schlick F, GGX D, height-correlated Smith G2, Lambert diffuse)."""

    fresnel: str = "schlick"
    ndf: str = "ggx"
    lambda_form: str = "exact"
    g2: str = "height_correlated"
    correlation: str = "exp"
    diffuse: str = "lambert"
    multiscatter: bool = False
    anisotropic: bool = False
    internal: bool = False  # Schlick evaluated at the transmitted angle (n1 > n2)
    # the dielectric F0 times the row's specular_color (glTF KHR_materials_specular's
    # coloured F0); off: the G-buffer's one F0 in every channel, the field not read
    specular_color: bool = False
    # --- thin film (RTR4 §9.11): F replaced by a film's interference reflectance ---
    thin_film: bool = False
    sheen: str = "none"  # sheen (RTR4 §9.10): the cloth layer's NDF, SHEEN_MODELS
    clearcoat: str = "none"  # clear coat (RTR4 §9.12): a CLEARCOAT_MODELS name
    diffraction: str = "none"  # diffraction (RTR4 §9.11): a DIFFRACTION_MODELS name
    fiber: str = "none"  # micro-cylinder fibres (RTR4 §9.10): a FIBER_MODELS name
    # the empirical cloth's wrapped cosine (RTR4 §9.10): a CLOTH_WRAP_FORMS name
    cloth_wrap_form: str = "filament"

    def defines(self) -> dict[str, int]:
        """The preprocessor defines that select this model in glsl/brdf/model.glsl
        (``MODEL_CODE_FIELDS``)."""
        return {c.define: c.code(getattr(self, c.attr)) for c in MODEL_CODE_FIELDS}

    def describe(self) -> str:
        """A short label naming every non-default choice, e.g. 'beckmann + separable'."""
        parts = [
            getattr(self, name)
            for name in ("fresnel", "ndf", "g2", "diffuse")
            if getattr(self, name) != getattr(DEFAULT_MODEL, name)
        ]
        if self.lambda_form != "exact":
            parts.append(f"{self.lambda_form} Lambda")
        if self.g2 in ("direction_correlated", "height_direction_correlated"):
            parts.append(f"{self.correlation} lambda(phi)")
        flags = ("multiscatter", "anisotropic", "internal", "specular_color", "thin_film")
        parts += [name for name in flags if getattr(self, name)]
        if self.sheen != "none":  # sheen (RTR4 §9.10)
            parts.append(f"{self.sheen} sheen")
        if self.clearcoat != "none":  # clear coat (RTR4 §9.12)
            parts.append(f"{self.clearcoat} clear coat")
        if self.diffraction != "none":  # diffraction (RTR4 §9.11)
            parts.append(f"{self.diffraction} diffraction")
        if self.fiber != "none":  # micro-cylinder fibres (RTR4 §9.10)
            parts.append(f"{self.fiber} fibre")
        if self.cloth_wrap_form != "filament":  # the empirical cloth's wrap (RTR4 §9.10)
            parts.append(f"{self.cloth_wrap_form} wrap")
        return " + ".join(parts) or "standard"


DEFAULT_MODEL = Model()


# Each material field's default (material_fields.py): ModelParams's.
_DEFAULTS: dict[str, Any] = {f.name: f.default for f in MATERIAL_FIELDS}


def _array(name: str) -> Callable[[], np.ndarray]:
    """A factory of material field ``name``'s default as a fresh float64 array (a colour
    or a 4-vector)."""
    return lambda: np.array(_DEFAULTS[name], np.float64)


@dataclass(frozen=True)
class ModelParams:
    """Per-material numbers of the optional models (each broadcasts like Surface's fields).

    One attribute per field of app/common/material_fields.py MATERIAL_FIELDS, in its order,
    with its default (its texel, unit, range and meaning are declared there).
    Indices are relative: to the medium the light arrives from (``medium_ior``), so the
    RTR4's "in water" values follow from dividing by 1.33.
    """

    # generalised Schlick: F at 90 degrees, 1/p; conductor n / n1, k / n1; dielectric n2 / n1
    f90: np.ndarray = field(default_factory=_array("f90"))
    fresnel_exponent: float = _DEFAULTS["fresnel_exponent"]
    eta: np.ndarray = field(default_factory=_array("eta"))
    eta_dielectric: float = _DEFAULTS["eta_dielectric"]
    k: np.ndarray = field(default_factory=_array("k"))
    gtr_gamma: float = _DEFAULTS["gtr_gamma"]  # GTR tail exponent (2 = GGX)
    # the dielectric F0's colour: F0 = f0_dielectric specular_color (white: f0 alone)
    specular_color: np.ndarray = field(default_factory=_array("specular_color"))
    # 1: the G-buffer's RT6 RGB scales specular_color, 0: sheen_color (a texture of either)
    specular_color_map: float = _DEFAULTS["specular_color_map"]
    # 1: RT6's A scales sheen_roughness, 0: the clear coat's strength (a texture of either)
    sheen_roughness_map: float = _DEFAULTS["sheen_roughness_map"]
    # --- thin film (RTR4 §9.11): nm (0 = the base's Fresnel alone), n2 / n1, n2, strength
    # (glTF iridescenceFactor), nm where a thickness map reads 0 ---
    film_thickness: float = _DEFAULTS["film_thickness"]
    film_eta: float = _DEFAULTS["film_eta"]
    film_ior: float = _DEFAULTS["film_ior"]
    film_factor: float = _DEFAULTS["film_factor"]
    film_thickness_min: float = _DEFAULTS["film_thickness_min"]
    # --- sheen (RTR4 §9.10): colour (black = no layer), perceptual roughness ---
    sheen_color: np.ndarray = field(default_factory=_array("sheen_color"))
    sheen_roughness: float = _DEFAULTS["sheen_roughness"]
    # --- clear coat (RTR4 §9.12): strength, perceptual roughness, coat / medium index,
    # transmittance at normal incidence through the coat once ---
    clearcoat: float = _DEFAULTS["clearcoat"]
    clearcoat_roughness: float = _DEFAULTS["clearcoat_roughness"]
    clearcoat_eta: float = _DEFAULTS["clearcoat_eta"]
    clearcoat_color: np.ndarray = field(default_factory=_array("clearcoat_color"))
    # --- diffraction grating (RTR4 §9.11): groove spacing d, peak-to-valley depth (nm) ---
    grating_period: float = _DEFAULTS["grating_period"]
    grating_depth: float = _DEFAULTS["grating_depth"]
    # --- empirical cloth (RTR4 §9.10, diffuse = "cloth_empirical"): (k_rim, a_rim,
    # k_inner, a_inner), k_diff, c_scatter, w, k_sheen c_sheen ---
    cloth_rim_inner: np.ndarray = field(default_factory=_array("cloth_rim_inner"))
    cloth_diffuse: float = _DEFAULTS["cloth_diffuse"]
    cloth_scatter: np.ndarray = field(default_factory=_array("cloth_scatter"))
    cloth_wrap: float = _DEFAULTS["cloth_wrap"]
    cloth_sheen: np.ndarray = field(default_factory=_array("cloth_sheen"))
    # --- micro-cylinder fibres (RTR4 §9.10), radians: rotation, curvature, gamma_v; k_d ---
    fiber_rotation: float = _DEFAULTS["fiber_rotation"]
    fiber_curvature: float = _DEFAULTS["fiber_curvature"]
    fiber_gamma_v: float = _DEFAULTS["fiber_gamma_v"]
    fiber_kd: float = _DEFAULTS["fiber_kd"]
    # --- transmission and volume (RTR4 §14.5): attenuation colour, transmission share;
    # thickness (object units, 0 thin-walled), attenuation distance (0: none) ---
    attenuation_color: np.ndarray = field(default_factory=_array("attenuation_color"))
    transmission: float = _DEFAULTS["transmission"]
    thickness: float = _DEFAULTS["thickness"]
    attenuation_distance: float = _DEFAULTS["attenuation_distance"]
    dispersion: float = _DEFAULTS["dispersion"]  # 20 / Abbe number (0: one index)


if [f.name for f in fields(ModelParams)] != list(FIELDS):
    raise ValueError("ModelParams: its attributes must be MATERIAL_FIELDS's, in order")

# Where a table keyed by surface constants too (app/frame/materials.py, constant surfaces)
# holds them, after the model texels (MATERIAL_TEXELS, material_fields.py): (base colour
# RGB, metallic), (perceptual roughness, F0, 0, 0). The G-buffer then stores only the
# normal, depth and row (docs/gbuffer.md).
SURFACE_TEXEL = MATERIAL_TEXELS
SURFACE_TEXELS = 2


def model_codes(model: Model) -> tuple[int, int, int]:
    """The (Fresnel, specular, diffuse) codes of ``model`` in texel 3 of its table row, read
    by the uber lighting shader (``fetch_model_codes``): each choice of
    ``MODEL_CODE_FIELDS`` shifted into its channel. Small integers, exact in float32."""
    codes = dict.fromkeys(_CODE_CHANNELS, 0)
    for c in MODEL_CODE_FIELDS:
        codes[c.channel] |= c.code(getattr(model, c.attr)) << c.shift
    return codes["g"], codes["b"], codes["a"]


def model_from_codes(fresnel: int, specular: int, diffuse: int) -> Model:
    """Inverse of ``model_codes``."""
    codes = dict(zip(_CODE_CHANNELS, (fresnel, specular, diffuse), strict=True))
    return Model(**{c.attr: c.value(codes[c.channel]) for c in MODEL_CODE_FIELDS})


# Each field's (texel, first channel, end channel, name), grouped by the layers the row
# holds always and those it holds only where their model is on.
_Slot = tuple[int, int, int, str]


def _slots(layer: Layer) -> list[_Slot]:
    """The slots of ``layer``'s fields, in the table's order."""
    return [
        (f.texel, f.first, f.first + f.size, f.name)
        for f in MATERIAL_FIELDS
        if f.layer == layer.name
    ]


_LAYER_SLOTS = {name: _slots(layer) for name, layer in LAYERS.items()}
_ALWAYS_SLOTS = [s for layer in LAYERS.values() if layer.packed_always for s in _slots(layer)]
_SWITCHED_SLOTS = [(layer, _slots(layer)) for layer in LAYERS.values() if not layer.packed_always]


def pack_model_params(
    params: list[ModelParams], groups: list[int], models: list[Model] | None = None
) -> np.ndarray:
    """The lighting pass's material table: (M, MATERIAL_TEXELS, 4) float32, one row of RGBA
    texels per material id: texel 3 (model group, Fresnel code, specular code, diffuse
    code), the others each field of MATERIAL_FIELDS at its texel and channels. The fields
    of a layer held always (the clear coat's, the cloth's, the fibre's, ...) are on every
    row, their defaults where a material has none, so that the layer's formulas stay
    finite (and equal the base) even where a pass forces them on, and a table packed
    without its models (the tests' kernels) still shades such a row as the twin; those of
    the thin film and the grating only where the row's model has them (zeros elsewhere).
    ``models`` gives each row's model (``model_codes``; only the uber lighting shader reads
    the codes); without it every row gets the standard model's."""
    table = np.zeros((max(len(params), 1), MATERIAL_TEXELS, 4), np.float32)
    models = models if models is not None else [DEFAULT_MODEL] * len(params)
    # Slices take a number or an RGB triple as they are (np.broadcast_to per texel cost a
    # viewer slider step more than the rest of the table).
    for row, (p, group, model) in enumerate(zip(params, groups, models, strict=True)):
        out = table[row]
        out[MODEL_CODES_TEXEL] = [group, *model_codes(model)]
        for texel, first, end, name in _ALWAYS_SLOTS:
            out[texel, first:end] = getattr(p, name)
        for layer, slots in _SWITCHED_SLOTS:
            if layer.on(model):
                for texel, first, end, name in slots:
                    out[texel, first:end] = getattr(p, name)
    return table


def unpack_model_params(texels: np.ndarray) -> ModelParams:
    """Inverse of one row of ``pack_model_params`` (float32 values widened to float64). A
    field past the row's texels keeps its default, and so does a layer whose ``present``
    channel is not positive (a table from before its texels: zero); the thin film's and the
    grating's texels are read as they are (zeros where the row's model has none)."""
    t = np.asarray(texels, np.float64)
    values: dict[str, Any] = {}
    for layer in LAYERS.values():
        slots = _LAYER_SLOTS[layer.name]
        if layer.present is not None:
            name, channel = layer.present
            f = FIELDS[name]
            if t.shape[0] <= max(s[0] for s in slots) or t[f.texel, f.first + channel] <= 0.0:
                continue
        for texel, first, end, name in slots:
            if texel >= t.shape[0]:  # a table from before the field's texel: its default
                continue
            values[name] = (
                float(t[texel, first]) if end - first == 1 else t[texel, first:end].copy()
            )
    return ModelParams(**values)


def _glsl_struct() -> list[str]:
    lines = [
        "// Per-material numbers of the optional models (app/common/material_fields.py,",
        "// generated); indices are relative to the medium the light arrives from.",
        "struct ModelParams {",
    ]
    lines += [
        f"    {f.glsl_type} {f.name};  // {f.layer}, texel {f.texel}.{f.channels}"
        + (f" ({f.unit})" if f.unit else "")
        for f in MATERIAL_FIELDS
    ]
    return [*lines, "};"]


def _glsl_fetch() -> list[str]:
    texels = sorted({f.texel for f in MATERIAL_FIELDS})
    lines = [
        "// Row ``id`` of the material table (MATERIAL_TEXELS RGBA32F texels per material, then",
        "// SURFACE_TEXELS more for constant surfaces; app/common/models.py pack_model_params).",
        "ModelParams fetch_model_params(sampler2D table, int id) {",
    ]
    lines += [f"    vec4 t{t} = texelFetch(table, ivec2({t}, id), 0);" for t in texels]
    args = [f"t{f.texel}.{f.channels}" for f in MATERIAL_FIELDS]
    lines.append("    return ModelParams(")
    lines += [
        f"        {arg}{',' if i + 1 < len(args) else ''}  // {f.name}"
        for i, (arg, f) in enumerate(zip(args, MATERIAL_FIELDS, strict=True))
    ]
    lines += ["    );", "}"]
    lines += [
        "// The model group of material ``id``: which lighting permutation shades its pixels.",
        "int fetch_model_group(sampler2D table, int id) {",
        f"    return int(texelFetch(table, ivec2({MODEL_CODES_TEXEL}, id), 0).r);",
        "}",
    ]
    return lines


def _glsl_uber() -> list[str]:
    """UBER_MODELS 1 (glsl/brdf/model.glsl): each model name a global that
    ``fetch_model_codes`` sets per pixel from texel 3 (``MODEL_CODE_FIELDS``)."""
    lines = [
        "#ifdef UBER_MODELS",
        "#if UBER_MODELS",
        "// Run-time model codes of the pixel being shaded (fetch_model_codes). A pass that",
        "// also defines one of the compile-time names fails to compile (macro redefinition).",
    ]
    lines += [f"int uber_{c.define.lower()};" for c in MODEL_CODE_FIELDS]
    lines += [f"#define {c.define} uber_{c.define.lower()}" for c in MODEL_CODE_FIELDS]
    lines += [
        "// Sets the run-time model codes from texel 3 of material ``id`` (exact small",
        "// integers in float32; app/common/models.py model_codes).",
        "void fetch_model_codes(sampler2D table, int id) {",
        f"    ivec4 c = ivec4(texelFetch(table, ivec2({MODEL_CODES_TEXEL}, id), 0));",
    ]
    for c in MODEL_CODE_FIELDS:
        shifted = f"(c.{c.channel} >> {c.shift})" if c.shift else f"c.{c.channel}"
        lines.append(f"    uber_{c.define.lower()} = {shifted} & {(1 << c.width) - 1};")
    return [*lines, "}", "#endif", "#endif"]


@cache
def material_glsl() -> str:
    """The GLSL side of the material row, generated from MATERIAL_FIELDS and
    MODEL_CODE_FIELDS: the ``ModelParams`` struct, ``fetch_model_params``,
    ``fetch_model_group`` and, under UBER_MODELS, the run-time model codes with
    ``fetch_model_codes``. app/gl/shaders.py writes it into every program's header."""
    return "\n".join([*_glsl_struct(), *_glsl_fetch(), *_glsl_uber()])


def unpack_model(texels: np.ndarray) -> tuple[int, Model]:
    """The model group and the model of one row of ``pack_model_params`` (texel 3)."""
    group, fresnel, specular, diffuse = (int(x) for x in np.asarray(texels)[3])
    return group, model_from_codes(fresnel, specular, diffuse)


@dataclass(frozen=True)
class MaterialParams:
    """A material after presets and defaults: what the G-buffer and the material table store."""

    base_color: tuple[float, float, float]
    metallic: float
    roughness: float
    f0: float  # normal-incidence reflectance of the dielectric part
    anisotropy: float = 0.0
    model: Model = DEFAULT_MODEL
    params: ModelParams = field(default_factory=ModelParams)
