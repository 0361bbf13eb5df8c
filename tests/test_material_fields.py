"""The material row is declared once (app/common/material_fields.py): every field packs at
the texel and channels its declaration names and unpacks back, the GLSL fetch (generated
into every program's header) reads it there, and its default is the same in the table,
``ModelParams`` and the scene schema."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.common.material_fields import (
    FIELDS,
    LAYERS,
    MATERIAL_FIELDS,
    MATERIAL_TEXELS,
    MODEL_CODES_TEXEL,
    MaterialField,
    scene_default,
    scene_keys,
)
from app.common.models import (
    MODEL_CODE_FIELDS,
    Model,
    ModelParams,
    model_codes,
    model_from_codes,
    pack_model_params,
    unpack_model_params,
)
from app.gl.kernel import run_kernel
from app.scene.model import Material

# A model with each layer on (the thin film's and the grating's texels are packed only
# there), and one with every layer on at once (the Model itself checks no combination).
LAYER_ON = {
    "core": Model(),
    "clearcoat": Model(clearcoat="filament"),
    "sheen": Model(sheen="charlie"),
    "thin_film": Model(thin_film=True),
    "grating": Model(diffraction="grating"),
    "cloth": Model(diffuse="cloth_empirical"),
    "fiber": Model(fiber="sadeghi"),
}
ALL_ON = Model(
    clearcoat="filament", sheen="charlie", thin_film=True, diffraction="grating",
    diffuse="cloth_empirical", fiber="sadeghi",
)  # fmt: skip


def _other(f: MaterialField) -> float | np.ndarray:
    """A value of ``f`` other than its default, inside its range, exact in float32 and
    positive (a layer's ``present`` channel must be)."""
    values = [f.low + (f.high - f.low) * (0.25 + 0.125 * i) for i in range(f.size)]
    values = [float(np.float32(v)) for v in values]
    assert values != list(np.atleast_1d(f.default)), f.name
    return values[0] if f.size == 1 else np.array(values)


def _as_row(value: float | tuple | np.ndarray) -> list[float]:
    """``value`` as the float32 numbers the table stores, widened."""
    return np.atleast_1d(np.asarray(value, np.float32)).astype(np.float64).tolist()


def test_layers_cover_every_field_and_each_model_turns_its_own_on() -> None:
    """Every layer has fields and a model that turns it on; the thin film's and the
    grating's texels alone are written only where their model is on (every bundled
    scene's table depends on it, byte for byte)."""
    assert {f.layer for f in MATERIAL_FIELDS} == set(LAYERS) == set(LAYER_ON)
    switched = {name for name, layer in LAYERS.items() if not layer.packed_always}
    assert switched == {"thin_film", "grating"}
    for name, model in LAYER_ON.items():
        on = {layer for layer, decl in LAYERS.items() if decl.on(model)}
        assert on == {"core", name}, name


@pytest.mark.parametrize("f", MATERIAL_FIELDS, ids=lambda f: f.name)
def test_each_field_packs_at_its_texel_and_round_trips(f: MaterialField) -> None:
    """Pack -> unpack returns the default and another value (float32-rounded); the value
    lies at the declared texel and channels and nowhere else changes; a layer held only
    where its model is on leaves zeros elsewhere."""
    model = LAYER_ON[f.layer]
    base = pack_model_params([ModelParams()], [0], [model])[0]
    for value in (f.default, _other(f)):
        row = pack_model_params([ModelParams(**{f.name: value})], [0], [model])[0]
        back = unpack_model_params(row)
        assert _as_row(getattr(back, f.name)) == _as_row(value), (f.name, value)
        assert row[f.texel, f.first : f.first + f.size].tolist() == _as_row(value)
        changed = row != base
        changed[f.texel, f.first : f.first + f.size] = False
        assert not changed.any(), f"{f.name} moved {np.argwhere(row != base).tolist()}"
        for other in MATERIAL_FIELDS:
            if other is not f:
                want = getattr(unpack_model_params(base), other.name)
                assert _as_row(getattr(back, other.name)) == _as_row(want), other.name
    off = pack_model_params([ModelParams(**{f.name: _other(f)})], [0], [Model()])[0]
    held = off[f.texel, f.first : f.first + f.size].tolist()
    assert held == (_as_row(_other(f)) if f.packed_always else [0.0] * f.size), f.name


def test_the_row_is_as_wide_as_its_texels() -> None:
    used = {f.texel for f in MATERIAL_FIELDS} | {MODEL_CODES_TEXEL}
    assert used == set(range(MATERIAL_TEXELS))
    table = pack_model_params([ModelParams()], [0], [ALL_ON])
    assert table.shape == (1, MATERIAL_TEXELS, 4)


def test_the_code_fields_round_trip_every_value() -> None:
    """Each code field, at each of its values, alone: model_from_codes inverts
    model_codes, and the value sits at its shift in its channel."""
    for c in MODEL_CODE_FIELDS:
        for value in c.names if c.names is not None else (False, True):
            model = Model(**{c.attr: value})
            codes = dict(zip("gba", model_codes(model), strict=True))
            assert model_from_codes(*codes.values()) == model, (c.attr, value)
            base = dict(zip("gba", model_codes(Model()), strict=True))
            mask = ((1 << c.width) - 1) << c.shift
            assert codes[c.channel] & mask == c.code(value) << c.shift
            assert codes[c.channel] & ~mask == base[c.channel] & ~mask, c.attr


def _distinct_params() -> ModelParams:
    """Every component of every field a different float32-exact number."""
    values = {}
    for i, f in enumerate(MATERIAL_FIELDS):
        numbers = [1.0 + i + 0.125 * k for k in range(f.size)]
        values[f.name] = numbers[0] if f.size == 1 else np.array(numbers)
    return ModelParams(**values)


def test_glsl_fetch_reads_each_field_at_its_texel(gl_egl) -> None:
    """fetch_model_params (the generated GLSL) reads each field from the texel and
    channels the table declares: once from a row whose every channel holds its own
    position, once from a row pack_model_params wrote."""
    ctx = gl_egl.ctx
    positions = np.zeros((1, MATERIAL_TEXELS, 4), np.float32)
    positions[0] = np.arange(MATERIAL_TEXELS * 4, dtype=np.float32).reshape(-1, 4) + 1.0
    params = _distinct_params()
    packed = pack_model_params([params], [0], [ALL_ON])
    tables = np.concatenate([positions, packed])
    textures = []

    def bind(program, unit: int) -> None:
        tex = ctx.texture((MATERIAL_TEXELS, 2), 4, tables.tobytes(), dtype="f4")
        textures.append(tex)
        tex.use(unit)
        program["u_materials"].value = unit

    try:
        for f in MATERIAL_FIELDS:
            pad = ", 0.0" * (4 - f.size)
            out = run_kernel(
                ctx,
                ["brdf/model.glsl"],
                f"ModelParams p = fetch_model_params(u_materials, int(x.x));\n"
                f"result = vec4(p.{f.name}{pad});",
                {"x": np.array([0.0, 1.0])},
                bind=bind,
                declarations="uniform sampler2D u_materials;",
            )
            where = [f.texel * 4 + c + 1.0 for c in range(f.first, f.first + f.size)]
            assert out[0, : f.size].tolist() == where, f.name
            assert out[1, : f.size].tolist() == _as_row(getattr(params, f.name)), f.name
    finally:
        for tex in textures:
            tex.release()


# The scene key(s) a field is made from, with its layer on, and how the row holds them.
SCENE_LAYER_ON = {
    "core": {},
    "clearcoat": {"clearcoat": 0.5},
    "sheen": {"sheen_color": [0.5, 0.5, 0.5]},
    "thin_film": {"thin_film": True},
    "grating": {"diffraction": "grating"},
    "cloth": {"diffuse": "cloth_empirical"},
    "fiber": {"fiber": "sadeghi"},
}


def _row_value_of_scene_defaults(f: MaterialField) -> object:
    """What the row should hold for ``f`` when a scene leaves its keys unset (in air)."""
    names = [k.name for k in f.keys]
    if f.name == "cloth_rim_inner":
        return [*scene_default("cloth_rim"), *scene_default("cloth_inner")]  # type: ignore[misc]
    if f.name == "cloth_sheen":
        return scene_default("cloth_sheen") * np.asarray(scene_default("cloth_sheen_color"))
    if f.name == "fresnel_exponent":  # fresnel_p = 1/exponent: unset, the exponent's default
        return f.default
    if names[0] in SCENE_LAYER_ON[f.layer]:  # the key that turns the layer on
        return SCENE_LAYER_ON[f.layer][names[0]]
    (key,) = f.keys
    value = scene_default(names[0])
    return math.radians(value) if key.unit == "deg" else value  # type: ignore[arg-type]


@pytest.mark.parametrize("f", [f for f in MATERIAL_FIELDS if f.keys], ids=lambda f: f.name)
def test_a_scene_without_the_key_gets_the_tables_default(f: MaterialField) -> None:
    """With its layer on and its keys unset, the schema resolves a field to the declared
    scene default (in the row's unit); without the layer a material packs the table's
    own defaults, as ModelParams() does."""
    on = Material(**SCENE_LAYER_ON[f.layer]).resolve()
    got = np.atleast_1d(getattr(on.params, f.name)).tolist()
    assert got == np.atleast_1d(_row_value_of_scene_defaults(f)).tolist(), f.name
    assert np.array_equal(getattr(ModelParams(), f.name), f.default)
    plain = Material().resolve()
    model = LAYER_ON[f.layer]
    row = pack_model_params([plain.params], [0], [model])[0]
    table = pack_model_params([ModelParams()], [0], [model])[0]
    where = (f.texel, slice(f.first, f.first + f.size))
    if f.layer == "thin_film":  # a scene's film is 400 nm thick where it turns one on
        assert row[where].tolist() == _as_row(_row_value_of_scene_defaults(f)), f.name
    else:
        assert row[where].tolist() == table[where].tolist(), f.name


@pytest.mark.parametrize("name", sorted(scene_keys()))
def test_the_schema_accepts_the_declared_range(name: str) -> None:
    """The scene schema's bounds of each key are the table's (per channel for a list)."""
    prop = Material.model_json_schema()["properties"][name]
    kinds = [s for s in prop.get("anyOf", [prop]) if s.get("type") != "null"]
    (schema,) = kinds
    schema = schema.get("items", schema)
    low = schema.get("minimum", schema.get("exclusiveMinimum"))
    key = scene_keys()[name]
    assert (low, schema["maximum"]) == (key.low, key.high), name
    control = key.control
    if control is not None and not control.color:
        assert key.low <= control.low < control.high <= key.high, name


def test_model_params_has_the_tables_fields_in_order() -> None:
    """ModelParams's attributes are the table's (its positional order too)."""
    assert list(FIELDS) == list(ModelParams.__dataclass_fields__)
