"""The G-buffer's layout, declared once, and a G-buffer read back to the CPU.

``GBUFFER_TARGETS`` lists the colour targets in binding order: each one's channels (all,
and with constant surfaces the ones kept), its storage per encoding, the define that says
it exists, its signed channels and the ``GBufferData`` fields it fills. ``GBufferLayout``
picks the targets of one G-buffer and derives from the list what every other place needs:
the targets allocated and their locations (app/render/gbuffer.py ``GBuffer``), the bytes
per pixel (app/render/limits.py, the bench), the ``GBUFFER_*`` defines; and
``glsl_declarations`` writes the GLSL outputs and samplers into each program's header
(app/gl/shaders.py), so no GLSL file restates the targets. docs/gbuffer.md documents the
layout and precision; architecture.md, "Adding a G-buffer target", the steps.

``GBufferData``: every field float32, rows top to bottom, with the meaning documented
below whatever the targets' storage (a unorm16 target's signed values are mapped back to
[-1, 1] on readback, as the decode does). ``ENCODINGS`` names the storages a scene's
``render.gbuffer`` chooses between.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.common.extension_maps import FACTOR_TARGET, FACTOR_TARGETS

# Storage of the colour targets per ``render.gbuffer`` value (docs/gbuffer.md, "Encodings"):
# RT0 base colour + metallic, then the targets holding octahedral directions (RT1 normal +
# roughness + F0, RT3 tangent + anisotropy, RT4 coat normal). RT2 (view depth, material id)
# is RG32F in every encoding. ``f16``: RGBA16F, a float16 per channel; ``unorm16``: GL_RGBA16,
# a uniform grid of 65536 steps over [0, 1], the signed values (octahedral coordinates,
# anisotropy) mapped from [-1, 1] (Cigolle et al. 2014, "A Survey of Efficient
# Representations for Independent Unit Vectors": the octahedral map on a uniform grid);
# ``f32``: RGBA32F. The default is the one whose own error is a small part of the
# pipeline's budget, measured in docs/gbuffer.md: only f32 is.
ENCODINGS: dict[str, tuple[str, str]] = {
    "f16": ("f16", "f16"),
    "unorm16": ("unorm16", "unorm16"),
    "unorm16_base": ("unorm16", "f32"),  # base colour and metallic in unorm16, the rest f32
    "f32": ("f32", "f32"),
}
ENCODING_NAMES = tuple(ENCODINGS)
DEFAULT_ENCODING = "f32"
# Bytes of one texel's channel in each storage, and moderngl's dtype of it ("nu2" is
# GL_RGBA16, 16-bit unsigned normalised, colour-renderable in GL 3.3).
STORAGE_BYTES = {"f16": 2, "unorm16": 2, "f32": 4}
STORAGE_DTYPES = {"f16": "f2", "unorm16": "nu2", "f32": "f4"}


def encoding_defines(encoding: str) -> dict[str, int]:
    """The defines of every pass that writes or decodes a G-buffer of ``encoding``
    (passes/gbuffer.frag, gbuffer/decode.glsl): GBUFFER_UNORM_DIRECTIONS where the
    direction targets are unorm16 (their signed values then pass through snorm_to_unorm /
    unorm_to_snorm). Nothing for
    float targets, so their programs compile exactly as before the encodings existed."""
    return {"GBUFFER_UNORM_DIRECTIONS": 1} if ENCODINGS[encoding][1] == "unorm16" else {}


# The storage a target takes under each ``render.gbuffer`` encoding, by its role.
BASE_STORAGE = {name: pair[0] for name, pair in ENCODINGS.items()}  # RT0
DIRECTION_STORAGE = {name: pair[1] for name, pair in ENCODINGS.items()}  # RT1, RT3, RT4
FLOAT32_STORAGE = dict.fromkeys(ENCODINGS, "f32")  # RT2: a depth and an exact integer id
# RT5: radiance has no upper bound a unorm could hold, so float16 with f16, else float32
RADIANCE_STORAGE = {name: "f16" if name == "f16" else "f32" for name in ENCODINGS}
# RT7: distances in pixels, a few pixels at most, whatever the encoding: float16 (11 bits)
HALF_STORAGE = dict.fromkeys(ENCODINGS, "f16")


@dataclass(frozen=True)
class GBufferTarget:
    """One colour target of the G-buffer: everything the Python side needs to allocate,
    bind, declare and read it back (app/render/gbuffer.py ``GBuffer`` iterates
    ``GBUFFER_TARGETS``; ``glsl_declarations`` writes its GLSL declarations)."""

    name: str  # GBuffer's attribute; "g_" + name in GLSL (output and sampler)
    channels: int  # 2 or 4
    storage: dict[str, str]  # encoding -> storage ("f16", "unorm16", "f32")
    # With constant surfaces: the channels still allocated (0: the target is absent) and
    # the material-table surface texel (SURFACE_TEXEL + this) that holds the channels
    # left out, which ``read`` and decode.glsl fetch_surface take from the pixel's row.
    constant_channels: int
    surface_texel: int | None = None
    # The define that says the target exists (None: always), its value in a program that
    # does not name it (the generated header sets it), and whether a G-buffer without the target
    # names it as 0 (else it is named only where present: the define came later, and the
    # programs of scenes without the target kept their defines).
    define: str | None = None
    default: int = 0
    named_when_absent: bool = False
    # Channels that hold signed values ([-1, 1]): a unorm16 target stores them mapped to
    # [0, 1] (snorm_to_unorm) and reads them back through unorm_to_snorm.
    signed: tuple[int, ...] = ()
    # The GBufferData fields it fills: one field takes every channel, several one each.
    fields: tuple[str, ...] = ()
    # The order in which a layout past MAX_COLOR_TARGETS leaves it out, lowest first (None:
    # never): a factor target's (app/common/extension_maps.py FactorTarget.shed).
    shed: int | None = None

    @property
    def glsl_name(self) -> str:
        """The GLSL output of the G-buffer pass and the decode's sampler uniform."""
        return f"g_{self.name}"

    @property
    def location_define(self) -> str | None:
        """GBUFFER_LOCATION_<NAME>: an optional target's framebuffer location."""
        return None if self.define is None else f"GBUFFER_LOCATION_{self.name.upper()}"

    def channels_in(self, constant_surfaces: bool) -> int:
        """The channels allocated: all, or with constant surfaces ``constant_channels``."""
        return self.constant_channels if constant_surfaces else self.channels


def _factor_target(name: str) -> GBufferTarget:
    """The G-buffer target of a factor target (app/common/extension_maps.py): four
    channels stored as RT0 is, kept with constant surfaces, its own GBufferData field,
    left out past the draw buffers in its declared order."""
    factor = FACTOR_TARGET[name]
    return GBufferTarget(name, 4, BASE_STORAGE, constant_channels=4, define=factor.define,
                         fields=(name,), shed=factor.shed)  # fmt: skip


# The G-buffer's colour targets in the order they are bound: each present one at the next
# framebuffer location (docs/gbuffer.md). A DEPTH24 renderbuffer does the z-test and is
# not listed: it is never sampled or read back.
GBUFFER_TARGETS: tuple[GBufferTarget, ...] = (
    # RT0: base colour RGB (linear), metallic
    GBufferTarget("base_color", 4, BASE_STORAGE, constant_channels=0, surface_texel=0,
                  fields=("base_color",)),
    # RT1: octahedral normal (x, y), perceptual roughness, F0
    GBufferTarget("normal", 4, DIRECTION_STORAGE, constant_channels=2, surface_texel=1,
                  signed=(0, 1), fields=("normal",)),
    # RT2: linear view depth in metres (0 where nothing was drawn), material id
    GBufferTarget("depth", 2, FLOAT32_STORAGE, constant_channels=2,
                  fields=("depth", "material_id")),
    # RT3: octahedral tangent (x, y), anisotropy, 0; where a material is anisotropic
    GBufferTarget("tangent", 4, DIRECTION_STORAGE, constant_channels=4,
                  define="GBUFFER_TANGENT", default=1, named_when_absent=True,
                  signed=(0, 1, 2), fields=("tangent",)),
    # RT4: octahedral clear-coat normal (x, y); where a coat's normal is not its base's
    GBufferTarget("coat_normal", 2, DIRECTION_STORAGE, constant_channels=2,
                  define="GBUFFER_COAT_NORMAL", named_when_absent=True, signed=(0, 1),
                  fields=("coat_normal",)),
    # RT5: emitted radiance RGB, occlusion factor; where a material emits or occludes
    GBufferTarget("emission", 4, RADIANCE_STORAGE, constant_channels=4,
                  define="GBUFFER_EMISSION", fields=("emission",)),
    # RT6: per-pixel scales of the material row's sheen or specular colour (RGB; the row's
    # specular_color_map says which) and clear-coat strength or sheen roughness (A; the
    # row's sheen_roughness_map), from glTF's sheenColorTexture / specularColorTexture and
    # clearcoatTexture / sheenRoughnessTexture; where a material has one (1 where none).
    # Its channels are declared by the maps (app/common/extension_maps.py EXTENSION_MAPS).
    _factor_target("layer_maps"),
    # RT7: the distance in pixels from the pixel centre to the drawn surface's edge along
    # +x, -x, +y, -y (window axes; 16 where no edge comes nearer), for the geometric edge
    # resolve; only with render.antialiasing = "gbaa" (docs/antialiasing.md)
    GBufferTarget("edge", 4, HALF_STORAGE, constant_channels=4, define="GBUFFER_EDGE",
                  fields=("edge",)),
    # RT8: per-pixel factors of glTF's clearcoatRoughnessTexture (R, on the row's
    # clearcoat_roughness), iridescenceTexture (G, on film_factor) and
    # iridescenceThicknessTexture (B: the film's thickness mix(film_thickness_min,
    # film_thickness, B)); A unused (1); where a material has one (1 where none)
    _factor_target("coat_film_maps"),
)  # fmt: skip
OPTIONAL_TARGETS = tuple(t.name for t in GBUFFER_TARGETS if t.define is not None)
if {t.name for t in FACTOR_TARGETS if t.gbuffer} - set(OPTIONAL_TARGETS):
    raise ValueError("a G-buffer factor target (app/common/extension_maps.py) has no target")
# The most colour targets one G-buffer pass may write: GL 3.3's least GL_MAX_DRAW_BUFFERS.
MAX_COLOR_TARGETS = 8
# The optional targets a layout past MAX_COLOR_TARGETS leaves out, first to last: the
# factor targets by their declared order (RT8, then RT6), whose materials then use the
# rows' own numbers (only a frame with every other target needs this).
SHED_TARGETS = tuple(
    t.name for t in sorted(
        (t for t in GBUFFER_TARGETS if t.shed is not None), key=lambda t: t.shed or 0
    )
)  # fmt: skip
# The optional targets of a program that names none of their defines (RT3 alone).
DEFAULT_OPTIONAL = frozenset(t.name for t in GBUFFER_TARGETS if t.define is not None and t.default)
# The layout's other defines and their values in a program that does not name them.
MODE_DEFAULTS = {"GBUFFER_UNORM_DIRECTIONS": 0, "GBUFFER_CONSTANT_SURFACES": 0}


def optional_defines(present: Mapping[str, bool]) -> dict[str, int]:
    """The presence defines of the optional targets, ``present`` naming each of them
    (``MaterialTable.gbuffer_defines`` decides): 1 where present, 0 or left out where
    absent (``GBufferTarget.named_when_absent``)."""
    if set(present) != set(OPTIONAL_TARGETS):
        raise ValueError(
            f"the optional G-buffer targets are {OPTIONAL_TARGETS}, not {tuple(present)}"
        )
    out: dict[str, int] = {}
    for target in GBUFFER_TARGETS:
        if target.define is not None and (present[target.name] or target.named_when_absent):
            out[target.define] = int(present[target.name])
    return out


def _allocated(
    optional: frozenset[str], constant_surfaces: bool
) -> list[tuple[GBufferTarget, int]]:
    """(target, channels) of every target allocated, in binding order."""
    out = []
    for target in GBUFFER_TARGETS:
        if target.define is not None and target.name not in optional:
            continue
        channels = target.channels_in(constant_surfaces)
        if channels:
            out.append((target, channels))
    return out


def _optional_present(defines: Mapping[str, object]) -> frozenset[str]:
    """The optional targets a program's defines say exist (the defaults where unnamed)."""
    return frozenset(
        t.name for t in GBUFFER_TARGETS
        if t.define is not None and bool(defines.get(t.define, t.default))
    )  # fmt: skip


@dataclass(frozen=True)
class GBufferLayout:
    """Which targets a G-buffer has and how they are stored: the encoding, the optional
    targets present and whether surfaces are constant. Allocation, bytes per pixel,
    locations and defines are all read from ``GBUFFER_TARGETS`` through it."""

    encoding: str = DEFAULT_ENCODING
    optional: frozenset[str] = DEFAULT_OPTIONAL
    constant_surfaces: bool = False

    def __post_init__(self) -> None:
        unknown = set(self.optional) - set(OPTIONAL_TARGETS)
        if unknown or self.encoding not in ENCODINGS:
            raise ValueError(f"no G-buffer layout {self.encoding!r} with {sorted(unknown)}")

    @classmethod
    def from_defines(
        cls, encoding: str, defines: Mapping[str, object], constant_surfaces: bool = False
    ) -> GBufferLayout:
        """The layout of ``MaterialTable.gbuffer_defines()`` (``optional_defines``)."""
        return cls(encoding, _optional_present(defines), constant_surfaces)

    def targets(self) -> list[tuple[GBufferTarget, int]]:
        """(target, channels allocated) of every target present, in binding order: the
        index is the framebuffer location."""
        return _allocated(self.optional, self.constant_surfaces)

    def fits(self) -> bool:
        """Whether its colour targets are at most MAX_COLOR_TARGETS."""
        return len(self.targets()) <= MAX_COLOR_TARGETS

    def fitted(self) -> GBufferLayout:
        """This layout, less the SHED_TARGETS (in order) it needs to leave out to fit."""
        layout = self
        for name in SHED_TARGETS:
            if layout.fits():
                break
            layout = GBufferLayout(
                layout.encoding, layout.optional - {name}, layout.constant_surfaces
            )
        return layout

    def storage(self, target: GBufferTarget) -> str:
        """The target's storage under this layout's encoding."""
        return target.storage[self.encoding]

    def bytes_per_pixel(self) -> int:
        """The colour targets' bytes per pixel as allocated (the DEPTH24 z-test not
        counted): the one count that app/render/limits.py charges and the bench reports."""
        return sum(ch * STORAGE_BYTES[self.storage(t)] for t, ch in self.targets())

    def locations(self) -> dict[str, int]:
        """Target name -> framebuffer location, the targets present only."""
        return {t.name: i for i, (t, _) in enumerate(self.targets())}

    def defines(self) -> dict[str, int]:
        """The defines of every pass that writes or decodes these targets: the optional
        targets' presence (as ``MaterialTable.gbuffer_defines``), the encoding's,
        GBUFFER_CONSTANT_SURFACES where surfaces are constant, and each optional target's
        location (GBUFFER_LOCATION_<NAME>: a layout location must be a literal)."""
        out = optional_defines({name: name in self.optional for name in OPTIONAL_TARGETS})
        out |= encoding_defines(self.encoding)
        if self.constant_surfaces:
            out["GBUFFER_CONSTANT_SURFACES"] = 1
        for location, (target, _) in enumerate(self.targets()):
            if target.location_define is not None:
                out[target.location_define] = location
        return out


def glsl_declarations(defines: Mapping[str, object]) -> list[str]:
    """The G-buffer's lines of a program's header (app/gl/shaders.py), from the program's
    ``defines``: the layout's defines it does not name, at their defaults (the optional
    targets' presence, GBUFFER_UNORM_DIRECTIONS, GBUFFER_CONSTANT_SURFACES, and the location
    of each optional target present), then two macros for the targets present:
    GBUFFER_OUTPUTS, the G-buffer pass's ``layout(location = ...) out`` declarations, and
    GBUFFER_SAMPLERS, the decode's ``uniform sampler2D`` ones (passes/gbuffer.frag and
    gbuffer/decode.glsl expand them; no GLSL file lists the targets); GBUFFER_SAMPLE, the
    texelFetch index the decode reads (0: the level; under GBUFFER_SAMPLES, whose samplers
    are sampler2DMS, the int ``gbuffer_sample`` the program declares), and
    GBUFFER_SIZE(t), a target's size in either."""
    lines: list[str] = []
    resolved: dict[str, object] = dict(defines)
    defaults = {t.define: t.default for t in GBUFFER_TARGETS if t.define is not None}
    for name, value in (defaults | MODE_DEFAULTS).items():
        if name not in resolved:
            resolved[name] = value
            lines.append(f"#define {name} {value}")
    constant = bool(resolved["GBUFFER_CONSTANT_SURFACES"])
    outputs, samplers = [], []
    for location, (target, channels) in enumerate(
        _allocated(_optional_present(resolved), constant)
    ):
        where = str(location)
        if target.location_define is not None:
            if target.location_define not in resolved:
                lines.append(f"#define {target.location_define} {location}")
            where = target.location_define
        outputs.append(f"layout(location = {where}) out vec{channels} {target.glsl_name};")
        samplers.append(f"uniform sampler2D {target.glsl_name};")
    lines.append("#define GBUFFER_OUTPUTS " + " ".join(outputs))
    # GBUFFER_SAMPLES = n: the decode reads a multisampled G-buffer of n samples
    # (render.antialiasing = "msaa", app/render/msaa.py), sample ``gbuffer_sample``
    samples = int(resolved.get("GBUFFER_SAMPLES", 0) or 0)
    if samples:
        samplers = [s.replace("sampler2D ", "sampler2DMS ") for s in samplers]
        lines += ["#define GBUFFER_SAMPLE gbuffer_sample", "#define GBUFFER_SIZE(t) textureSize(t)"]
    else:
        lines += ["#define GBUFFER_SAMPLE 0", "#define GBUFFER_SIZE(t) textureSize(t, 0)"]
    lines.append("#define GBUFFER_SAMPLERS " + " ".join(samplers))
    return lines


@dataclass
class GBufferData:
    """The G-buffer of one frame, (H, W) per pixel."""

    base_color: np.ndarray  # (H, W, 4): linear base colour (F0 for metals), metallic
    normal: np.ndarray  # (H, W, 4): octahedral normal (x, y), perceptual roughness, F0
    depth: np.ndarray  # (H, W): view depth in metres, 0 = background
    # (H, W, 4): octahedral tangent (x, y), anisotropy, 0; zeros where the G-buffer has no
    # tangent target (no anisotropic material in the frame)
    tangent: np.ndarray
    material_id: np.ndarray  # (H, W): the row of the material table (an exact integer)
    # (H, W, 2): octahedral clear-coat normal (x, y); None where the G-buffer has no coat
    # normal target (no coat's normal differs from its base's: the coat shades with the
    # normal above)
    coat_normal: np.ndarray | None = None
    # (H, W, 4): emitted radiance (linear RGB), occlusion factor of environment light; None
    # where the G-buffer has no RT5 (nothing emits and no occlusion map: glTF 2.0 core)
    emission: np.ndarray | None = None
    # (H, W, 4): the factors the extension maps put on the row's sheen or specular colour
    # (RGB) and clear-coat strength (A); None where the G-buffer has no RT6 (no such map)
    layer_maps: np.ndarray | None = None
    # (H, W, 4): distances in pixels from the centre to the surface's edge along +x, -x,
    # +y (up), -y, 16 where none is nearer; None where the G-buffer has no edge target
    # (render.antialiasing is not "gbaa")
    edge: np.ndarray | None = None
    # (H, W, 4): the factors the clear-coat roughness and iridescence maps put on the row's
    # clearcoat_roughness (R), film_factor (G) and film thickness (B, between
    # film_thickness_min and film_thickness); None where the G-buffer has no RT8
    coat_film_maps: np.ndarray | None = None

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: the pixels a surface was drawn into."""
        return np.isfinite(self.depth) & (self.depth > 0.0)
