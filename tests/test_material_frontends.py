"""The three material front-ends (a scene file's [materials.x], glTF with its KHR_materials_*
extensions, an OBJ's MTL) seen by one set of semantic checks (app/common/material_checks.py):
each check refuses the inconsistent material and passes its consistent twin; the scene
file refuses each with its key; the MTL refuses what it can express with its statement; the
glTF reader names the JSON key of a problem, and drops the textures the glTF specification
itself disables (a black emissiveFactor, a clearcoatFactor or anisotropyStrength of 0) with
a warning, where a scene file refuses the same key."""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.common.material_checks import MAX_RADIANCE, MaterialProblem, material_problems
from app.common.models import MaterialParams
from app.errors import InputError
from app.scene.geometry import build_parts
from app.scene.loader import load_scene, parse_scene
from tests.gltf_builder import GltfBuilder, png_rgb
from tests.test_assets import QUAD
from tests.test_gltf import SCENE

GREY = MaterialParams((0.8, 0.8, 0.8), 0.0, 0.5, 0.04)


def _with(params: MaterialParams, model: dict | None = None, extra: dict | None = None,
          **material: object) -> MaterialParams:  # fmt: skip
    """``params`` with fields of its Model, its ModelParams and itself replaced."""
    return replace(
        params,
        model=replace(params.model, **(model or {})),
        params=replace(params.params, **(extra or {})),
        **material,
    )


COATED = _with(GREY, extra={"clearcoat": 1.0, "clearcoat_eta": 1.5})
ANISOTROPIC = _with(GREY, model={"anisotropic": True}, anisotropy=0.5)
FIBER = _with(GREY, model={"fiber": "kajiya_kay"})

# (the problem's key, the inconsistent material and maps, a consistent twin and maps)
CASES = [
    ("anisotropy_map", GREY, {"anisotropy"}, ANISOTROPIC, {"anisotropy"}),
    ("anisotropy_direction_map", GREY, {"anisotropy_direction"},
     ANISOTROPIC, {"anisotropy_direction"}),
    ("lambda_form", _with(GREY, model={"lambda_form": "rational"}), set(),
     _with(GREY, model={"lambda_form": "rational", "ndf": "beckmann"}), set()),
    ("g2", _with(GREY, model={"g2": "hammon", "ndf": "beckmann"}), set(),
     _with(GREY, model={"g2": "hammon"}), set()),
    ("anisotropy", _with(ANISOTROPIC, model={"ndf": "blinn_phong"}), set(),
     _with(ANISOTROPIC, model={"ndf": "beckmann"}), set()),
    ("multiscatter", _with(ANISOTROPIC, model={"multiscatter": True}), set(),
     _with(GREY, model={"multiscatter": True}), set()),
    ("diffraction", _with(GREY, model={"diffraction": "grating", "ndf": "beckmann"}), set(),
     _with(GREY, model={"diffraction": "grating"}), set()),
    ("clearcoat_normal_map", GREY, {"coat_normal"}, COATED, {"coat_normal"}),
    ("clearcoat_ior", _with(COATED, extra={"clearcoat_eta": 0.9}), set(), COATED, set()),
    ("clearcoat", _with(COATED, model={"internal": True}), set(), COATED, set()),
    ("emissive_map", GREY, {"emissive"}, GREY, {"emissive"}),  # emissive: see EMISSIVE
    ("thin_film", _with(FIBER, model={"thin_film": True}), set(), FIBER, set()),
    ("sheen_color", _with(FIBER, model={"sheen": "charlie"}), set(), FIBER, set()),
    ("clearcoat", _with(FIBER, extra={"clearcoat": 1.0}), set(), FIBER, set()),
    ("metallic", _with(FIBER, metallic=0.5), set(), FIBER, set()),
]  # fmt: skip
EMISSIVE = {"emissive_map": ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))}


@pytest.mark.parametrize(("key", "bad", "bad_maps", "good", "good_maps"), CASES)
def test_each_check_refuses_the_inconsistent_and_passes_its_twin(
    key: str, bad: MaterialParams, bad_maps: set, good: MaterialParams, good_maps: set
) -> None:
    """One problem, named by its scene-file key, and none for the consistent twin."""
    black, lit = EMISSIVE.get(key, ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    problems = material_problems(bad, bad_maps, black)
    assert [p.key for p in problems] == [key], problems
    assert material_problems(good, good_maps, lit) == []


def test_emission_bound_is_on_the_product() -> None:
    """The factor times its strength is what the HDR image must hold; a zero strength
    keeps a non-zero factor and its map consistent (the map multiplies the factor)."""
    assert material_problems(GREY, set(), (1.0, 0.5, 0.0), MAX_RADIANCE) == []
    (problem,) = material_problems(GREY, set(), (1.0, 0.5, 0.0), 2.0 * MAX_RADIANCE)
    assert problem.key == "emissive_strength"
    assert material_problems(GREY, {"emissive"}, (1.0, 0.0, 0.0), 0.0) == []


def test_consistent_values_past_the_scene_files_ranges_pass() -> None:
    """The checks are about consistency, not the TOML ranges: glTF's ior 0 (eta 1e6)
    passes, under a coat too."""
    ior_zero = _with(COATED, extra={"eta_dielectric": 1e6}, f0=1.0)
    assert material_problems(ior_zero, {"coat_normal"}) == []


# --- the scene file: each check refused with its key ---

TOML = [
    ("anisotropy_map", {"anisotropy_map": "t.png"}),
    ("anisotropy_direction_map", {"anisotropy_direction_map": "t.png"}),
    ("lambda_form", {"lambda_form": "rational"}),
    ("g2", {"g2": "hammon", "ndf": "beckmann"}),
    ("anisotropy", {"anisotropy": 0.5, "ndf": "blinn_phong"}),
    ("multiscatter", {"anisotropy": 0.5, "multiscatter": True}),
    ("diffraction", {"diffraction": "grating", "ndf": "beckmann"}),
    ("clearcoat_normal_map", {"clearcoat_normal_map": "t.png"}),
    ("clearcoat_ior", {"clearcoat": 1.0, "clearcoat_ior": 1.2, "medium_ior": 1.33}),
    ("clearcoat", {"clearcoat": 1.0, "ior": 1.2, "medium_ior": 1.33}),
    ("emissive_map", {"emissive_map": "t.png"}),
    ("emissive_strength", {"emissive": [MAX_RADIANCE, 0.0, 0.0], "emissive_strength": 2.0}),
    ("thin_film", {"fiber": "kajiya_kay", "thin_film": True}),
    ("sheen_color", {"fiber": "kajiya_kay", "sheen_color": [0.5, 0.5, 0.5]}),
    ("clearcoat", {"fiber": "kajiya_kay", "clearcoat": 1.0}),
    ("metallic", {"fiber": "kajiya_kay", "metallic": 0.5}),
]


def _toml_scene(material: dict) -> dict:
    return {
        "camera": {"position": [0.0, 0.0, 3.0], "target": [0.0, 0.0, 0.0]},
        "lights": [{"type": "directional", "direction": [0.0, 0.0, -1.0]}],
        "materials": {"m": material},
        "objects": [{"shape": "plane", "material": "m"}],
    }


@pytest.mark.parametrize(("key", "material"), TOML)
def test_scene_file_refuses_each_problem_with_its_key(
    tmp_path: Path, key: str, material: dict
) -> None:
    png_rgb((128, 128, 255)).save(tmp_path / "t.png")
    with pytest.raises(InputError) as caught:
        parse_scene(_toml_scene(material), tmp_path / "inline.toml")
    assert caught.value.key == f"materials.m.{key}", str(caught.value)
    assert "\n" not in str(caught.value)


# --- the MTL ---

OBJ_QUAD = "mtllib quad.mtl\nusemtl m\n" + QUAD  # test_assets.py's unit quad, one material


def _mtl_parts(folder: Path, mtl: str) -> list:
    (folder / "quad.obj").write_text(OBJ_QUAD, encoding="utf-8")
    (folder / "quad.mtl").write_text(mtl, encoding="utf-8")
    (folder / "scene.toml").write_text(SCENE.format(file="quad.obj"), encoding="utf-8")
    return build_parts(load_scene(folder / "scene.toml"))


def test_mtl_refuses_an_emission_past_the_bound(tmp_path: Path) -> None:
    """Ke past MAX_RADIANCE would overflow the HDR image: refused as a scene file's
    emissive x emissive_strength is, naming the MTL file, the material and Ke."""
    with pytest.raises(InputError) as caught:
        _mtl_parts(tmp_path, "newmtl m\nKe 2e15 0 0\n")
    message = str(caught.value)
    assert caught.value.key == "objects[0].file", message
    assert "quad.mtl: newmtl m: Ke: emissive x emissive_strength must not exceed" in message
    assert "\n" not in message
    (part,) = _mtl_parts(tmp_path, "newmtl m\nKe 1e15 0 0\n")  # at the bound: kept
    assert part.layers[0].emissive == (1e15, 0.0, 0.0)


def test_mtl_black_ke_drops_its_map(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """map_Ke multiplies Ke: with Ke 0 0 0 the map emits nothing; it is dropped with a
    warning (a scene file refuses emissive_map without emissive)."""
    png_rgb((255, 255, 255)).save(tmp_path / "e.png")
    with caplog.at_level(logging.WARNING):
        (part,) = _mtl_parts(tmp_path, "newmtl m\nKe 0 0 0\nmap_Ke e.png\n")
    assert "emissive" not in part.layers[0].maps
    assert "newmtl m: map_Ke: Ke is black" in caplog.text
    (part,) = _mtl_parts(tmp_path, "newmtl m\nKe 1 1 1\nmap_Ke e.png\n")
    assert "emissive" in part.layers[0].maps


# --- glTF ---


def _gltf_parts(folder: Path, material: pygltflib.Material, with_texture: str | None = None):
    b = GltfBuilder()
    if with_texture is not None:
        index = b.texture(png_rgb((128, 128, 255)))
        ext = material.extensions.get(with_texture[0]) if material.extensions else None
        if ext is not None:
            ext[with_texture[1]] = {"index": index}
        else:
            setattr(material, with_texture[1], pygltflib.TextureInfo(index=index))
    b.quad(b.material(material))
    b.save(folder / "m.glb")
    (folder / "scene.toml").write_text(SCENE.format(file="m.glb"), encoding="utf-8")
    return build_parts(load_scene(folder / "scene.toml"))


@pytest.mark.parametrize(
    ("material", "texture", "role", "warning"),
    [
        (pygltflib.Material(), ("", "emissiveTexture"), "emissive",
         "materials[0].emissiveTexture: emissiveFactor is black"),
        (pygltflib.Material(extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 0.0}}),
         ("KHR_materials_clearcoat", "clearcoatNormalTexture"), "coat_normal",
         "clearcoatNormalTexture: clearcoatFactor is 0"),
        (pygltflib.Material(extensions={"KHR_materials_anisotropy": {}}),
         ("KHR_materials_anisotropy", "anisotropyTexture"), "anisotropy",
         "anisotropyTexture: anisotropyStrength is 0"),
    ],
)  # fmt: skip
def test_gltf_drops_the_textures_its_specification_disables(
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    material: pygltflib.Material,
    texture: tuple[str, str],
    role: str,
    warning: str,
) -> None:
    """What a scene file refuses (a map whose factor is missing) the glTF specification
    defines as disabled: the texture is not read, a warning names its key, and the material
    the shared checks see is consistent."""
    with caplog.at_level(logging.WARNING):
        (part,) = _gltf_parts(tmp_path, material, texture)
    layer = part.layers[0]
    assert role not in layer.maps and "anisotropy_direction" not in layer.maps
    assert warning in caplog.text
    assert material_problems(layer.params, layer.maps, layer.emissive) == []


def test_gltf_names_the_json_key_of_a_problem(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reader hands what it built to the shared checks and turns a problem into a
    GltfError naming the extension that gave it (no glTF the reader accepts is
    inconsistent today: every factor is bounded and the disabled layers dropped, so the
    problem is injected)."""
    import app.scene.gltf as gltf

    seen: list = []

    def one_problem(
        params: MaterialParams, maps: object, emissive: object, strength: float
    ) -> list[MaterialProblem]:
        seen.append((params, set(maps), tuple(emissive), strength))  # type: ignore[arg-type]
        return [MaterialProblem("clearcoat_normal_map", "applies only with clearcoat > 0")]

    monkeypatch.setattr(gltf, "material_problems", one_problem)
    coat = {"KHR_materials_clearcoat": {"clearcoatFactor": 0.5}}
    material = pygltflib.Material(emissiveFactor=[0.5, 0.25, 0.0], extensions=coat)
    with pytest.raises(InputError) as caught:
        _gltf_parts(tmp_path, material, ("KHR_materials_clearcoat", "clearcoatNormalTexture"))
    message = str(caught.value)
    assert "materials[0].extensions.KHR_materials_clearcoat: applies only with clearcoat > 0" in (
        message
    )
    assert "\n" not in message
    ((params, maps, emissive, strength),) = seen
    assert params.params.clearcoat == 0.5 and "coat_normal" in maps
    assert emissive == (0.5, 0.25, 0.0) and strength == 1.0
    assert np.isfinite(params.params.clearcoat_eta)
