"""The extension maps, declared once: the glTF ``KHR_materials_*`` textures that scale a
number of the material row per pixel, and the factor targets that carry their texels.

An ``ExtensionMap`` names the layer's map key, the glTF extension and texture key, the
texture's channel(s) and colour space, the ``FactorTarget`` and channel(s) (its slot) it
fills, and the row's field it applies to (a product, or a mix from another field) with
the row flag that picks it where two maps share a slot. A ``FactorTarget`` is a G-buffer
target of such factors (RT6 ``layer_maps``, RT8 ``coat_film_maps``: app/common/gbuffer.py
builds their ``GBufferTarget`` from it, with the order in which a layout past the draw
buffers leaves them out), or one only the passes that draw glass sample
(``transmission_maps``: the forward pass and the glass shadow pass; glass is not in the
G-buffer). Every channel of a factor target is 1 where its material has no map, so a
target left out costs only the per-pixel variation.

Derived from the declarations, nowhere restated: each map's bit and index in a layer's
``LAYER<i>_MAPS`` define (``MAP_BITS``, ``MAP_INDEX``, after the core maps ``CORE_MAPS``)
and their GLSL ``#define``s (``map_glsl``); the samplers and ``sample_<target>(uv)`` of
glsl/material/layers.glsl (``sampling_glsl``); the ``scale_by_<target>(p, f)`` of
glsl/brdf/material.glsl (``scaling_glsl``) and their float64 twin ``scale_row``; the
passes' call sites of every factor target (the WRITE_FACTOR_TARGETS, SAMPLE_FACTOR_TARGETS,
SCALE_BY_GBUFFER_FACTORS and SCALE_BY_FACTOR_TARGETS macros of the same two texts); which
targets a layer's maps need (``targets_of``); the glTF reader's texture keys, channels and
colour spaces (app/scene/gltf_extensions.py, app/scene/gltf.py). app/gl/shaders.py
splices the GLSL in where a file includes ``GENERATED_INCLUDES``' names.
docs/architecture.md, "Adding an extension texture", has the steps.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

# The layer maps that are not extension maps, in bit order: each one's bit is 1 << its
# position (glsl/material/layers.glsl reads them by hand: each has its own meaning).
CORE_MAPS = (
    "base_color",  # sRGB (decoded by the GL) or linear: multiplies base_color
    "metallic",  # R: multiplies metallic
    "anisotropy",  # R: multiplies anisotropy
    "normal_roughness",  # RGB: tangent-space normal, A: perceptual roughness (absolute)
    "f0",  # R: multiplies the dielectric F0 (baked blends, glTF specularTexture's A)
    "select",  # R: >= 0.5 picks layer 1's material row (baked blends)
    "coat_normal",  # RGB: the clear coat's tangent-space normal (layer 0 only)
    "emissive",  # sRGB: multiplies the emitted radiance (layer 0 only)
    "occlusion",  # R: ambient occlusion of environment light (layer 0 only)
    "anisotropy_direction",  # RG: direction of anisotropy in (t, b), 2 rg - 1 (layer 0)
)


@dataclass(frozen=True)
class FactorTarget:
    """Four channels of per-pixel factors on the material row, filled by extension maps."""

    name: str  # "layer_maps": the G-buffer target's name, sample_<name>, scale_by_<name>
    define: str  # the define that says it exists (compiles in its samplers and functions)
    # Whether the G-buffer stores it (its GBufferTarget: app/common/gbuffer.py); else only
    # the passes that draw glass sample it (forward, glass shadows: glass is not in the G-buffer).
    gbuffer: bool = True
    # The order in which a G-buffer layout past MAX_COLOR_TARGETS leaves it out, lowest
    # first (None: never); its materials then use the row's numbers alone.
    shed: int | None = None
    # The define of the only pass that applies it, where one pass alone does (the
    # transmission pass's TRANSMISSION); None: every pass that reads the material.
    pass_define: str | None = None

    @property
    def macro(self) -> str:
        """Its part of the generated macros' names (SAMPLE_LAYER_MAPS, ...)."""
        return self.name.upper()

    @property
    def condition(self) -> str:
        """The #if under which a program samples and applies it."""
        return self.define if self.pass_define is None else f"{self.define} && {self.pass_define}"


FACTOR_TARGETS: tuple[FactorTarget, ...] = (
    FactorTarget("layer_maps", "GBUFFER_LAYER_MAPS", shed=2),  # RT6
    FactorTarget("coat_film_maps", "GBUFFER_COAT_FILM_MAPS", shed=1),  # RT8
    FactorTarget(
        "transmission_maps", "TRANSMISSION_MAPS", gbuffer=False, pass_define="TRANSMISSION"
    ),
)
FACTOR_TARGET = {t.name: t for t in FACTOR_TARGETS}


@dataclass(frozen=True)
class ExtensionMap:
    """One glTF extension texture that scales a number of the material row per pixel."""

    key: str  # the layer's map key: u_<key>_map0, MAP_<KEY>, MAP_INDEX_<KEY>
    extension: str  # "KHR_materials_sheen"
    texture: str  # its textureInfo's property: "sheenColorTexture"
    channels: str  # the texture's channel(s) read: "rgb" (colour), else one of "rgba"
    srgb: bool  # a colour texture the GL decodes from sRGB; else linear, one channel
    target: str  # the FactorTarget it fills
    slot: str  # that target's channels it writes: "rgb", or one of "rgba"
    field: str  # the material row's field (app/common/material_fields.py) it applies to
    # The row's field the factor mixes from: field = mix(low, field, factor); None: the
    # factor multiplies the field.
    low: str | None = None
    # The row's flag (0 or 1) that says this map fills a slot another map also fills; the
    # map without one is the slot's default.
    selector: str | None = None

    @property
    def bit(self) -> int:
        """Its bit in a layer's LAYER<i>_MAPS define."""
        return MAP_BITS[self.key]

    @property
    def glsl_key(self) -> str:
        return self.key.upper()


# Bits follow the order: appending keeps every older map's bit (and its programs).
EXTENSION_MAPS: tuple[ExtensionMap, ...] = (
    # RT6 RGB: KHR_materials_sheen's sheen colour, or KHR_materials_specular's colour
    ExtensionMap("sheen_color", "KHR_materials_sheen", "sheenColorTexture", "rgb", True,
                 "layer_maps", "rgb", "sheen_color"),
    # RT6 A: KHR_materials_clearcoat's strength, or the sheen roughness
    ExtensionMap("clearcoat", "KHR_materials_clearcoat", "clearcoatTexture", "r", False,
                 "layer_maps", "a", "clearcoat"),
    ExtensionMap("specular_color", "KHR_materials_specular", "specularColorTexture", "rgb",
                 True, "layer_maps", "rgb", "specular_color", selector="specular_color_map"),
    ExtensionMap("sheen_roughness", "KHR_materials_sheen", "sheenRoughnessTexture", "a",
                 False, "layer_maps", "a", "sheen_roughness", selector="sheen_roughness_map"),
    # RT8: the coat's roughness, the film's strength, the film's thickness between the
    # row's minimum and maximum (KHR_materials_iridescence)
    ExtensionMap("clearcoat_roughness", "KHR_materials_clearcoat", "clearcoatRoughnessTexture",
                 "g", False, "coat_film_maps", "r", "clearcoat_roughness"),
    ExtensionMap("film_factor", "KHR_materials_iridescence", "iridescenceTexture", "r", False,
                 "coat_film_maps", "g", "film_factor"),
    ExtensionMap("film_thickness", "KHR_materials_iridescence", "iridescenceThicknessTexture",
                 "g", False, "coat_film_maps", "b", "film_thickness", low="film_thickness_min"),
    # glass, sampled by the transmission pass: KHR_materials_transmission's share and
    # KHR_materials_volume's thickness
    ExtensionMap("transmission", "KHR_materials_transmission", "transmissionTexture", "r",
                 False, "transmission_maps", "r", "transmission"),
    ExtensionMap("thickness", "KHR_materials_volume", "thicknessTexture", "g", False,
                 "transmission_maps", "g", "thickness"),
)  # fmt: skip
EXTENSION_MAP = {m.key: m for m in EXTENSION_MAPS}

# Maps read through another map's UVs and transform, never a transform of their own: the
# normal map's slope covariance (render.normal_filter = "lean"; app/textures/lean.py).
SHARED_UV_MAPS = ("slope_covariance",)

# Bit of each map in a layer's LAYER<i>_MAPS define, and its index (bit = 1 << index) in
# u_uv_transform0 (glsl/material/layers.glsl; app/render/uv.py).
MAP_INDEX: dict[str, int] = {
    key: i for i, key in enumerate((*CORE_MAPS, *(m.key for m in EXTENSION_MAPS), *SHARED_UV_MAPS))
}
MAP_BITS: dict[str, int] = {key: 1 << i for key, i in MAP_INDEX.items()}


def _check() -> None:
    """The declarations' invariants, refused at import: distinct keys, known targets,
    slots within four channels and apart from the other slots of their target, one
    default map per slot, one channel per linear texture."""
    if len(MAP_INDEX) != len(CORE_MAPS) + len(EXTENSION_MAPS) + len(SHARED_UV_MAPS):
        raise ValueError("an extension map's key repeats another map's")
    slots: dict[str, dict[str, list[ExtensionMap]]] = {}
    for m in EXTENSION_MAPS:
        if m.target not in FACTOR_TARGET:
            raise ValueError(f"{m.key}: no factor target {m.target!r}")
        if not m.slot or set(m.slot) - set("rgba") or len(set(m.slot)) != len(m.slot):
            raise ValueError(f"{m.key}: slot {m.slot!r} is not channels of rgba")
        if len(m.channels) != len(m.slot) or (not m.srgb and len(m.channels) != 1):
            raise ValueError(f"{m.key}: {m.channels!r} cannot fill slot {m.slot!r}")
        slots.setdefault(m.target, {}).setdefault(m.slot, []).append(m)
    for target, by_slot in slots.items():
        used = "".join(by_slot)
        if len(set(used)) != len(used):
            raise ValueError(f"{target}: slots {list(by_slot)} overlap")
        for slot, maps in by_slot.items():
            if sum(m.selector is None for m in maps) != 1:
                raise ValueError(f"{target}.{slot}: needs one map without a selector")


_check()


def slots(target: str) -> dict[str, list[ExtensionMap]]:
    """The slots of ``target`` in declaration order, each with its maps (the default last:
    the ``else`` of the selectors)."""
    out: dict[str, list[ExtensionMap]] = {}
    for m in EXTENSION_MAPS:
        if m.target == target:
            out.setdefault(m.slot, []).append(m)
    return {s: sorted(maps, key=lambda m: m.selector is None) for s, maps in out.items()}


def maps_of(target: str) -> frozenset[str]:
    """The map keys that fill ``target``."""
    return frozenset(m.key for m in EXTENSION_MAPS if m.target == target)


def targets_of(maps: Iterable[str]) -> frozenset[str]:
    """The factor targets a layer's maps (SurfaceLayer.maps keys) fill."""
    return frozenset(EXTENSION_MAP[k].target for k in maps if k in EXTENSION_MAP)


def selectors(maps: Iterable[str]) -> dict[str, float]:
    """The row's selector flags for a layer's maps: 1 for each map present that needs
    one, 0 for the other selectors of the slots those maps fill."""
    present = set(maps)
    out: dict[str, float] = {}
    for m in EXTENSION_MAPS:
        if m.selector is not None and any(o.key in present for o in slots(m.target)[m.slot]):
            out[m.selector] = 1.0 if m.key in present else 0.0
    return out


# --- GLSL, spliced in by app/gl/shaders.py where a file includes these names ---


def map_glsl() -> str:
    """MAP_<KEY> (its bit) and MAP_INDEX_<KEY> of every map, and MAP_COUNT."""
    lines = ["// Generated from app/common/extension_maps.py (MAP_BITS): the layer maps' bits"]
    lines += [f"#define MAP_{key.upper()} {bit}" for key, bit in MAP_BITS.items()]
    lines += [f"#define MAP_INDEX_{key.upper()} {i}" for key, i in MAP_INDEX.items()]
    lines.append(f"#define MAP_COUNT {len(MAP_INDEX)}")
    return "\n".join(lines)


def sampling_glsl() -> str:
    """Per factor target, under its define: the samplers of its maps and
    ``vec4 sample_<target>(vec2 uv)``, each map's texels in its slot (1 where the layer
    has no such map), read as any layer-0 map (sample_layer_map: its UV set and texture
    transform). A colour map's texture is sRGB-decoded RGB; a linear one holds its one
    channel in R (app/scene/gltf.py). Then the passes' call sites, as macros empty where a
    target is absent: WRITE_FACTOR_TARGETS(uv), the G-buffer pass's ``g_<target> =
    sample_<target>(uv);`` of each G-buffer target, and SAMPLE_FACTOR_TARGETS(uv), the
    forward pass's ``vec4 <target>_factors = sample_<target>(uv);`` of each target it
    applies (before any discard: the lookups' derivatives need the whole quad)."""
    lines = ["// Generated from app/common/extension_maps.py (EXTENSION_MAPS)"]
    for target in FACTOR_TARGETS:
        maps = [m for m in EXTENSION_MAPS if m.target == target.name]
        lines.append(f"#if {target.define}")
        lines += [f"uniform sampler2D u_{m.key}_map0;" for m in maps]
        lines.append(f"vec4 sample_{target.name}(vec2 uv) {{")
        lines.append("    vec4 f = vec4(1.0);")
        for m in maps:
            texels = "rgb" if m.srgb else "r"
            lines += [
                f"#if (LAYER0_MAPS & MAP_{m.glsl_key}) != 0",
                f"    f.{m.slot} = sample_layer_map(u_{m.key}_map0, uv, u_layer0.uv_scale, 0,",
                f"                           MAP_INDEX_{m.glsl_key}).{texels};",
                "#endif",
            ]
        lines += ["    return f;", "}", "#endif"]
    lines += _call_site_macros(
        _CallSite("SAMPLE_FACTOR_TARGETS", "SAMPLE", "uv",
                  lambda t: f"vec4 {t.name}_factors = sample_{t.name}(uv);"),
        _CallSite("WRITE_FACTOR_TARGETS", "WRITE", "uv",
                  lambda t: f"g_{t.name} = sample_{t.name}(uv);"),
    )  # fmt: skip
    return "\n".join(lines)


@dataclass(frozen=True)
class _CallSite:
    """One pass's call site of the factor targets, as generated macros: per target
    ``<prefix>_<TARGET>(<args>)`` expanding to ``body(target)``, and ``name(<args>)``, the
    targets' macros in a row."""

    name: str  # the macro over all targets: SAMPLE_FACTOR_TARGETS
    prefix: str  # a target's macro's: SAMPLE -> SAMPLE_LAYER_MAPS
    args: str  # the macros' parameters: "uv"
    body: Callable[[FactorTarget], str]  # what a present target's macro expands to


def _call_site_macros(every: _CallSite, gbuffer: _CallSite) -> list[str]:
    """The macros of two call sites, ``every`` of every factor target and ``gbuffer`` of
    the G-buffer's alone: each target's under its condition, empty where it is absent
    (one text, so a target's #if/#else holds both of its call sites), then the one of the
    G-buffer call site over its targets and the one of ``every`` over all."""
    lines = []
    for target in FACTOR_TARGETS:
        sites = [every, gbuffer] if target.gbuffer else [every]
        heads = [f"#define {site.prefix}_{target.macro}({site.args})" for site in sites]
        lines.append(f"#if {target.condition}")
        lines += [f"{head} {site.body(target)}" for head, site in zip(heads, sites, strict=True)]
        lines += ["#else", *heads, "#endif"]
    for site, targets in ((gbuffer, [t for t in FACTOR_TARGETS if t.gbuffer]),
                          (every, FACTOR_TARGETS)):  # fmt: skip
        calls = " ".join(f"{site.prefix}_{t.macro}({site.args})" for t in targets)
        lines.append(f"#define {site.name}({site.args}) {calls}")
    return lines


def _apply_glsl(m: ExtensionMap, value: str) -> str:
    if m.low is None:
        return f"p.{m.field} *= {value};"
    return f"p.{m.field} = mix(p.{m.low}, p.{m.field}, {value});"


def scaling_glsl() -> str:
    """Per factor target, under its define: ``ModelParams scale_by_<target>(ModelParams p,
    vec4 f)``: each slot's factors clamped to [0, 1] (NaN: 1, no change), applied to the
    field of the map its selector picks (a product, or a mix from ``low``). Then the
    passes' call sites, as macros empty where a target is absent:
    SCALE_BY_GBUFFER_FACTORS(p, px), the lighting pass's scaling of the decoded row by each
    G-buffer target's texel at px, and SCALE_BY_FACTOR_TARGETS(p), the forward pass's by
    the factors SAMPLE_FACTOR_TARGETS sampled."""
    lines = ["// Generated from app/common/extension_maps.py (EXTENSION_MAPS)"]
    for target in FACTOR_TARGETS:
        lines += [f"#if {target.define}",
                  f"ModelParams scale_by_{target.name}(ModelParams p, vec4 f) {{"]  # fmt: skip
        for slot, maps in slots(target.name).items():
            parts = [f"sanitize_value(f.{c}, 0.0, 1.0, 1.0)" for c in slot]
            kind = "float" if len(slot) == 1 else f"vec{len(slot)}"
            value = parts[0] if len(slot) == 1 else f"{kind}({', '.join(parts)})"
            lines.append(f"    {kind} f_{slot} = {value};")
            if len(maps) == 1:
                lines.append(f"    {_apply_glsl(maps[0], f'f_{slot}')}")
                continue
            for i, m in enumerate(maps):
                head = "if" if i == 0 else "} else if"
                if m.selector is None:
                    lines.append("    } else {")
                else:
                    lines.append(f"    {head} (p.{m.selector} > 0.5) {{")
                lines.append(f"        {_apply_glsl(m, f'f_{slot}')}")
            lines.append("    }")
        lines += ["    return p;", "}", "#endif"]
    lines += _call_site_macros(
        _CallSite("SCALE_BY_FACTOR_TARGETS", "SCALE_BY", "p",
                  lambda t: f"p = scale_by_{t.name}(p, {t.name}_factors);"),
        _CallSite("SCALE_BY_GBUFFER_FACTORS", "SCALE_BY_G", "p, px",
                  lambda t: f"p = scale_by_{t.name}(p, "
                            f"texelFetch(g_{t.name}, px, GBUFFER_SAMPLE));"),
    )  # fmt: skip
    return "\n".join(lines)


# app/gl/shaders.py: an #include of one of these names splices the generated text.
GENERATED_INCLUDES: dict[str, Callable[[], str]] = {
    "generated/map_bits.glsl": map_glsl,
    "generated/extension_sampling.glsl": sampling_glsl,
    "generated/extension_scaling.glsl": scaling_glsl,
}


# --- the float64 twin ---


def scale_row(params: Any, target: str, f: np.ndarray) -> Any:
    """``scaling_glsl``'s ``scale_by_<target>`` in float64: the row ``params`` (a
    ModelParams) with the factors ``f`` ((C, 4), already clamped to [0, 1]) applied per
    pixel, each slot to the field of the map its selector picks."""
    changes: dict[str, np.ndarray] = {}
    for slot, maps in slots(target).items():
        chosen = next(
            m for m in maps if m.selector is None or float(getattr(params, m.selector)) > 0.5
        )
        cols = ["rgba".index(c) for c in slot]
        value = f[:, cols[0]] if len(cols) == 1 else f[:, cols]
        field = np.asarray(getattr(params, chosen.field))
        if chosen.low is None:
            changes[chosen.field] = field * value
        else:
            low = getattr(params, chosen.low)
            changes[chosen.field] = low + (field - low) * value
    return replace(params, **changes)
