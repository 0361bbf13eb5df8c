"""The extension-map contract (app/common/extension_maps.py): one declaration per glTF
extension texture, from which the map bits, the G-buffer's factor targets and their
shedding, the GLSL sampling and scaling and the float64 twin's scaling all follow.

The GLSL each declaration generates is checked where it runs: the per-map renders of
tests/test_gltf_extension_maps.py, tests/test_gltf_coat_film_maps.py and the texture tests
of tests/test_transmission.py; here the generated ``scale_by_<target>`` of every factor
target against ``scale_row``, and what the derived tables must keep.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.common import extension_maps
from app.common.extension_maps import (
    EXTENSION_MAPS,
    FACTOR_TARGETS,
    MAP_BITS,
    ExtensionMap,
    sampling_glsl,
    scale_row,
    selectors,
    slots,
    targets_of,
)
from app.common.gbuffer import (
    GBUFFER_TARGETS,
    MAX_COLOR_TARGETS,
    OPTIONAL_TARGETS,
    SHED_TARGETS,
    GBufferData,
    GBufferLayout,
)
from app.common.models import (
    MaterialParams,
    Model,
    ModelParams,
    pack_model_params,
    unpack_model_params,
)
from app.gl.kernel import run_kernel
from app.scene.gltf_extensions import map_material_extensions

# The bits every map had before the declarations existed: a program's LAYER<i>_MAPS, and
# so its cache key and compiled code, stay what they were (appending keeps them).
BITS_BEFORE = {
    "base_color": 1, "metallic": 2, "anisotropy": 4, "normal_roughness": 8, "f0": 16,
    "select": 32, "coat_normal": 64, "emissive": 128, "occlusion": 256,
    "anisotropy_direction": 512, "sheen_color": 1024, "clearcoat": 2048,
    "specular_color": 4096, "sheen_roughness": 8192, "clearcoat_roughness": 16384,
    "film_factor": 32768, "film_thickness": 65536,
}  # fmt: skip


def test_appending_a_map_keeps_every_older_bit():
    assert {k: MAP_BITS[k] for k in BITS_BEFORE} == BITS_BEFORE
    assert len(set(MAP_BITS.values())) == len(MAP_BITS)


def test_the_gbuffer_factor_targets_and_their_shedding_follow_the_declarations():
    """Each G-buffer factor target is an optional target of four channels; the layout past
    the draw buffers leaves them out in their declared order (RT8 first), and a frame
    with every optional target then fits by leaving out RT8 alone."""
    declared = {t.name: t for t in FACTOR_TARGETS if t.gbuffer}
    by_name = {t.name: t for t in GBUFFER_TARGETS}
    for name, factor in declared.items():
        assert name in OPTIONAL_TARGETS and by_name[name].channels == 4
        assert by_name[name].define == factor.define and by_name[name].shed == factor.shed
        assert name in GBufferData.__dataclass_fields__  # read back, and decoded by the twin
    assert SHED_TARGETS == ("coat_film_maps", "layer_maps")
    every = GBufferLayout(optional=frozenset(OPTIONAL_TARGETS))
    assert len(every.targets()) == MAX_COLOR_TARGETS + 1
    assert every.fitted().optional == every.optional - {"coat_film_maps"}


def test_a_layer_needs_the_targets_its_maps_fill_and_the_selectors_say_which():
    assert targets_of(["base_color", "sheen_color", "film_factor"]) == {
        "layer_maps", "coat_film_maps"}  # fmt: skip
    assert targets_of(["transmission", "thickness"]) == {"transmission_maps"}
    assert targets_of(["normal_roughness"]) == frozenset()
    assert selectors(["specular_color"]) == {"specular_color_map": 1.0}
    assert selectors(["sheen_color", "clearcoat"]) == {
        "specular_color_map": 0.0, "sheen_roughness_map": 0.0}  # fmt: skip
    # every slot's maps: the selected ones first, the default (no selector) last
    for target in FACTOR_TARGETS:
        for maps in slots(target.name).values():
            assert maps[-1].selector is None


def _rows() -> list[ModelParams]:
    """Two rows with every field an extension map touches away from its default: the
    first with every selector 0, the second with every selector 1."""
    p = replace(
        ModelParams(),
        specular_color=np.array([0.9, 0.7, 0.5]), sheen_color=np.array([0.2, 0.4, 0.8]),
        sheen_roughness=0.6, clearcoat=0.7, clearcoat_roughness=0.3, film_factor=0.8,
        film_thickness=500.0, film_thickness_min=100.0, transmission=0.9, thickness=2.0,
    )  # fmt: skip
    flags = {m.selector for m in EXTENSION_MAPS if m.selector is not None}
    return [replace(p, **dict.fromkeys(flags, v)) for v in (0.0, 1.0)]


def _scaled_fields(gl, target: str) -> None:
    """Run scale_by_<target> (generated into brdf/material.glsl) on rows fetched from a
    packed table and random factors in [0, 1], and compare every field a declared map of
    the target applies to with scale_row's, for both values of each selector."""
    model = Model(thin_film=True, sheen="charlie_smith", clearcoat="filament")
    table = pack_model_params(_rows(), [0, 0], [model, model])
    rows = [unpack_model_params(table[i]) for i in range(2)]
    rng = np.random.default_rng(7)
    n = 32
    row = np.arange(n) % 2
    f = rng.uniform(0.0, 1.0, (n, 4))
    ctx = gl.ctx
    textures = []

    def bind(program, unit: int) -> None:
        tex = ctx.texture((table.shape[1], table.shape[0]), 4, table.tobytes(), dtype="f4")
        textures.append(tex)
        tex.use(unit)
        program["u_materials"].value = unit

    define = next(t.define for t in FACTOR_TARGETS if t.name == target)
    fields = sorted({m.field for m in extension_maps.EXTENSION_MAPS if m.target == target})
    f32 = f.astype(np.float32).astype(np.float64)
    try:
        for field in fields:
            size = np.size(getattr(rows[0], field))
            value = f"vec4(p.{field}, 0.0)" if size == 3 else f"vec4(p.{field}, 0.0, 0.0, 0.0)"
            body = (
                "ModelParams p = fetch_model_params(u_materials, int(x.x));\n"
                f"p = scale_by_{target}(p, f);\nresult = {value};"
            )
            got = run_kernel(
                ctx, ["brdf/material.glsl"], body, {"x": row.astype(np.float64), "f": f},
                defines={define: 1}, bind=bind, declarations="uniform sampler2D u_materials;",
            )  # fmt: skip
            for i in range(2):
                sel = row == i
                want = np.asarray(getattr(scale_row(rows[i], target, f32[sel]), field))
                if want.ndim == 0 or want.shape == (size,):  # the row's number, unscaled
                    want = np.broadcast_to(want, (sel.sum(), size))
                np.testing.assert_allclose(
                    got[sel, :size], want.reshape(sel.sum(), size), rtol=2e-6, atol=1e-6,
                    err_msg=f"{target}.{field}, row {i}",
                )  # fmt: skip
    finally:
        for tex in textures:
            tex.release()


@pytest.mark.gl
@pytest.mark.parametrize("target", [t.name for t in FACTOR_TARGETS])
def test_generated_scaling_is_the_twins(gl_egl, target):
    """Every factor target's generated scaling against the twin's. Fails where a slot's
    channels, its selector or the mix's ends differ between the GLSL and the twin."""
    _scaled_fields(gl_egl, target)


@pytest.mark.gl
def test_one_declaration_is_sampled_and_scaled_with_no_other_edit(gl_egl, monkeypatch):
    """A hypothetical texture declared on RT8's free A channel (scaling the row's
    film_ior) is, with no other edit, a map bit, a sampler writing f.a in
    sample_coat_film_maps, and a line of the GLSL scale_by_coat_film_maps that agrees with
    scale_row. Fails where any of them is written by hand instead of from the list."""
    new = ExtensionMap("film_ior_test", "KHR_test", "testTexture", "r", False,
                       "coat_film_maps", "a", "film_ior")  # fmt: skip
    maps = (*EXTENSION_MAPS, new)
    index = {**extension_maps.MAP_INDEX, new.key: len(extension_maps.MAP_INDEX)}
    monkeypatch.setattr(extension_maps, "EXTENSION_MAPS", maps)
    monkeypatch.setattr(extension_maps, "EXTENSION_MAP", {m.key: m for m in maps})
    monkeypatch.setattr(extension_maps, "MAP_INDEX", index)
    monkeypatch.setattr(extension_maps, "MAP_BITS", {k: 1 << i for k, i in index.items()})
    extension_maps._check()
    assert f"#define MAP_FILM_IOR_TEST {1 << len(index) - 1}" in extension_maps.map_glsl()
    glsl = sampling_glsl()
    assert "uniform sampler2D u_film_ior_test_map0;" in glsl
    assert "    f.a = sample_layer_map(u_film_ior_test_map0," in glsl
    assert targets_of(["film_ior_test"]) == {"coat_film_maps"}
    _scaled_fields(gl_egl, "coat_film_maps")  # film_ior among the compared fields


def test_the_reader_takes_each_declared_texture_with_its_channel_and_selector():
    """map_material_extensions reads a declared texture under its extension's key with the
    declared channel (transmissionTexture R, thicknessTexture G, sheenRoughnessTexture A)
    and sets the slot's selector; a texture the factor disables, or whose slot another
    map holds, is a note, not a map."""
    core = MaterialParams((1.0, 1.0, 1.0), 0.0, 0.5, 0.04)
    ext = {
        "KHR_materials_transmission": {"transmissionFactor": 1.0,
                                       "transmissionTexture": {"index": 0}},
        "KHR_materials_volume": {"thicknessFactor": 0.5, "thicknessTexture": {"index": 1}},
        "KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1],
                                "sheenRoughnessTexture": {"index": 2}},
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatTexture": {"index": 3}},
    }  # fmt: skip
    m = map_material_extensions(ext, core, "materials[0]")
    assert {k: t.channel for k, t in m.maps.items()} == {
        "transmission": "r", "thickness": "g", "sheen_roughness": "a"}  # fmt: skip
    assert m.maps["thickness"].key.endswith("KHR_materials_volume.thicknessTexture")
    assert m.params.params.sheen_roughness_map == 1.0  # RT6's A is the sheen roughness's
    assert any("clearcoatTexture: not supported beside a sheenRoughnessTexture" in note
               for note in m.notes)  # fmt: skip
    off = {
        "KHR_materials_transmission": {
            "transmissionFactor": 0.0,
            "transmissionTexture": {"index": 0},
        },
        "KHR_materials_volume": {"thicknessFactor": 0.5, "thicknessTexture": {"index": 1}},
    }
    m = map_material_extensions(off, core, "materials[0]")
    assert not m.maps and len(m.notes) == 2  # nothing transmits: both textures noted
