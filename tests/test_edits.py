"""The scene-edit module (app/scene/edits.py): key paths, strict and lenient edits, the
errors they give, and the whole-table swaps the renderer makes; and app/scene/sources.py,
where the API and the CLI find a scene."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from pydantic import ValidationError

from app.errors import InputError
from app.resources import scenes_dir
from app.scene.edits import (
    KEY_SYNTAX,
    KeyPathError,
    apply_edits,
    edited,
    edited_data,
    get_key,
    parse_key,
    replace_parts,
    set_key,
    toml_value,
)
from app.scene.loader import LoadedScene, load_scene, parse_scene, read_toml
from app.scene.sources import PYTHON_SCENE, scene_from, scene_path

LIGHTS = scenes_dir() / "sec4_lights.toml"  # materials ball and floor, eight lights
STAGE = scenes_dir() / "gltf_stage.toml"  # camera.from_file: a glTF file's camera


@pytest.fixture(scope="module")
def lights() -> LoadedScene:
    return load_scene(LIGHTS)


# --- key paths -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("key", "path"),
    [
        ("render.tonemap", ("render", "tonemap")),
        ("materials.gold-schlick.roughness", ("materials", "gold-schlick", "roughness")),
        ("lights[2].intensity", ("lights", 2, "intensity")),
        ("background[0]", ("background", 0)),
        ('materials."a.b[0]".g2', ("materials", "a.b[0]", "g2")),
        ("objects[0].size[1]", ("objects", 0, "size", 1)),
    ],
)
def test_parse_key(key: str, path: tuple) -> None:
    assert parse_key(key) == path
    assert parse_key(key, lenient=True) == path  # lenient reads every strict key alike


@pytest.mark.parametrize(
    "key",
    ["", "materials..fresnel", "lights[x].intensity", "lights.[0]", "render.", ".render",
     "lights[0]x", "a b", "materials.my mat.roughness", 'materials."open'],
)  # fmt: skip
def test_a_malformed_key_is_one_error_naming_origin_and_key(key: str) -> None:
    with pytest.raises(KeyPathError) as caught:
        parse_key(key, "jobs.toml")
    assert (caught.value.file, caught.value.key, caught.value.message) == (
        "jobs.toml",
        key,
        KEY_SYNTAX,
    )
    assert "\n" not in str(caught.value) and isinstance(caught.value, InputError)


def test_lenient_names_hold_what_a_file_may_quote() -> None:
    """The viewer's panels write ``materials.{name}`` for any name the file gives."""
    assert parse_key("materials.my mat.roughness", lenient=True) == (
        "materials",
        "my mat",
        "roughness",
    )
    for bad in ("materials..x", "lights[x]", "a.b]"):
        with pytest.raises(KeyPathError):
            parse_key(bad, lenient=True)


def test_get_key_reads_a_value_or_the_default() -> None:
    data = {"lights": [{"intensity": 2.0}], "render": {"tonemap": "aces"}}
    assert get_key(data, "lights[0].intensity") == 2.0
    assert get_key(data, ("render", "tonemap")) == "aces"
    for missing in ("lights[1].intensity", "camera.fov_y", "render.tonemap.x", "lights..x"):
        assert get_key(data, missing, "default") == "default"


def test_toml_value() -> None:
    assert toml_value([1, True, 'a"b', {"k": 0.5}]) == '[1, true, "a\\"b", { k = 0.5 }]'


# --- setting keys ---------------------------------------------------------------------------


def test_strict_set_needs_every_step_but_the_last() -> None:
    data = {"materials": {"gold": {"roughness": 0.3}}, "lights": [{"intensity": 1.0}]}
    set_key(data, ("materials", "gold", "metallic"), 1.0, "s.toml", "sweep")  # a default's key
    value = [1.0, 0.5, 0.2]
    set_key(data, ("lights", 0, "color"), value, "s.toml", "sweep")
    value[0] = 9.0  # a copy was set
    assert data["materials"]["gold"] == {"roughness": 0.3, "metallic": 1.0}
    assert data["lights"][0]["color"] == [1.0, 0.5, 0.2]
    set_key(data, ("materials", "gold", "roughness"), None, "s.toml", "sweep")  # None removes
    assert data["materials"]["gold"] == {"metallic": 1.0}


@pytest.mark.parametrize(
    ("path", "key", "message"),
    [
        (("materials", "gld", "roughness"), "materials.gld", "not in the scene (there: gold)"),
        (("lights", 1, "intensity"), "lights[1]", "no such entry: the list has 1 (indices 0..0)"),
        (("materials", 0), "materials[0]", "not a list: it takes no [N] index"),
        (("lights", "x"), "lights.x", "its parent is a list: index it with [N]"),
        (("lights", 0, "intensity", "x"), "lights[0].intensity.x", "its parent is a value"),
        (("lights", 0), "lights[0]", "a list entry is not removed by an edit: set the whole list"),
    ],
)
def test_a_missing_step_names_file_key_and_origin(path: tuple, key: str, message: str) -> None:
    data = {"materials": {"gold": {}}, "lights": [{"intensity": 1.0}]}
    value = None if path == ("lights", 0) else 1.0
    with pytest.raises(KeyPathError) as caught:
        set_key(data, path, value, "s.toml", "sweep")
    assert str(caught.value) == f"s.toml: {key}: {message} (sweep)"
    assert data == {"materials": {"gold": {}}, "lights": [{"intensity": 1.0}]}


def test_lenient_set_creates_the_tables_a_file_leaves_out() -> None:
    data: dict = {}
    apply_edits(data, {"render.tonemap": "aces", "materials.my mat.roughness": 0.2}, "f", "viewer",
                lenient=True)  # fmt: skip
    assert data == {"render": {"tonemap": "aces"}, "materials": {"my mat": {"roughness": 0.2}}}
    with pytest.raises(KeyPathError, match=r"f: lights\[0\]: no such entry: the list has 0"):
        apply_edits(data, {"lights[0].intensity": 1.0}, "f", "viewer", lenient=True)
    with pytest.raises(KeyPathError, match="f: render: not in the scene"):  # strict
        apply_edits({}, {"render.tonemap": "aces"}, "f", "batch")


def test_apply_edits_names_the_edit_that_failed() -> None:
    data = {"render": {}, "camera": {}}
    with pytest.raises(KeyPathError) as caught:
        apply_edits(data, [("render.tonemap", "aces"), ("camera.fov_y", 30.0), ("x.y", 1)],
                    "f", "walkthrough")  # fmt: skip
    assert caught.value.edit == 2
    with pytest.raises(KeyPathError) as caught:
        apply_edits(data, [("render.tonemap", "aces"), ("camera..fov_y", 1)], "f", "o")
    assert (caught.value.edit, caught.value.file) == (1, "o")


# --- edited scenes ---------------------------------------------------------------------------


def test_edited_validates_as_a_scene_file_and_changes_nothing(lights: LoadedScene) -> None:
    before = lights.scene.model_dump()
    out = edited(lights, {"materials.ball.roughness": 0.15, "lights[1].intensity": 3.0}, "o")
    assert out.scene.materials["ball"].roughness == 0.15 and out.scene.lights[1].intensity == 3.0
    assert out.path == lights.path and out.policy is lights.policy
    data = lights.scene.model_dump(exclude_none=True)
    data["materials"]["ball"]["roughness"] = 0.15
    data["lights"][1]["intensity"] = 3.0
    assert out.scene == parse_scene(data, lights.path).scene
    with pytest.raises(InputError) as caught:
        edited(lights, {"materials.ball.roughness": 1.5}, "o")
    assert not isinstance(caught.value, KeyPathError)  # the value is wrong, not the key
    assert (caught.value.file, caught.value.key) == (str(lights.path), "materials.ball.roughness")
    assert "less than or equal to 1" in caught.value.message
    with pytest.raises(InputError, match=r"materials\.ball\.roughnes: unknown key"):
        edited(lights, {"materials.ball.roughnes": 0.5}, "o")
    assert lights.scene.model_dump() == before


@pytest.mark.parametrize(
    "edits",
    [
        {"camera.fov_y": 30.0},
        {"camera.position": [1.0, 2.0, 3.0], "render.tonemap": "aces"},
        {"render.normal_filter": "naive"},
    ],
)
def test_camera_and_render_edits_equal_the_whole_scenes(lights: LoadedScene, edits) -> None:
    """The fast path (the camera and render tables validated alone) gives the scene that
    validating the whole edited data gives."""
    data = apply_edits(lights.scene.model_dump(exclude_none=True), edits, "f", "o")
    out = edited(lights, edits, "o").scene
    assert out == parse_scene(data, lights.path).scene
    assert out.materials is lights.scene.materials  # kept, not validated again


def test_a_refused_camera_value_is_the_scene_files_message(lights: LoadedScene) -> None:
    with pytest.raises(InputError) as caught:
        edited(lights, {"camera.fov_y": 500.0}, "o")
    assert str(caught.value) == (
        f"{lights.path}: camera.fov_y: Input should be less than 180 (got 500.0)"
    )


def test_lenient_edits_of_a_files_data() -> None:
    """The viewer's edits: the file as written (tables left out), a glTF file's camera
    resolved again when the camera table is edited."""
    data = read_toml(STAGE)
    base = parse_scene(dict(data), STAGE)
    new_data, out = edited_data(base, {"camera.exposure": 1.0}, "viewer", data=data,
                                lenient=True)  # fmt: skip
    assert new_data["camera"] == {"from_file": "Camera_0", "exposure": 1.0}
    assert "exposure" not in data["camera"]  # the caller's data is a copy
    want = base.scene.camera.model_copy(update={"exposure": 1.0})
    assert out.scene.camera == want  # the file's camera, not the default one
    lights_data = read_toml(LIGHTS)
    del lights_data["render"]
    base = parse_scene(dict(lights_data), LIGHTS)
    new_data, out = edited_data(base, {"render.tonemap": "aces"}, "viewer", data=lights_data,
                                lenient=True)  # fmt: skip
    assert new_data["render"] == {"tonemap": "aces"} and out.scene.render.tonemap == "aces"
    with pytest.raises(KeyPathError):
        edited(base, {"render.tonemap": "aces"}, "batch", data=lights_data)  # strict


def test_replace_parts(lights: LoadedScene) -> None:
    scene = lights.scene
    camera = scene.camera.model_copy(update={"fov_y": 20.0})
    swapped = replace_parts(scene, camera=camera, background=[0.5, 0.5, 0.5])
    assert swapped.camera is camera and swapped.materials is scene.materials
    materials = dict(scene.materials)
    materials["extra"] = scene.materials["ball"]
    assert set(replace_parts(scene, materials=materials).materials) == {*scene.materials, "extra"}
    lit = replace_parts(scene, lights=[{"type": "point", "position": [0, 1, 0]}])
    assert lit.lights[0].type == "point" and lit.camera == scene.camera  # tables become models
    with pytest.raises(ValidationError):
        replace_parts(scene, lights=[{"type": "laser"}])
    with pytest.raises(ValidationError):  # a table is not a camera: validated as the scene's
        replace_parts(scene, camera={"fov_y": 500.0})


# --- where a scene comes from ------------------------------------------------------------------


def test_scene_path_and_scene_from(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert scene_path("sec4_lights") == LIGHTS
    assert scene_path("nothing") == Path("nothing")  # loading it says there is no such file
    assert scene_path("sec4_lights.toml") == Path("sec4_lights.toml")  # a suffix: a path
    (tmp_path / "sec4_lights").write_text("")
    assert scene_path("sec4_lights") == Path("sec4_lights")  # a file here wins
    assert scene_from(str(LIGHTS)).scene == load_scene(LIGHTS).scene
    loaded = scene_from({"materials": {}}, base_dir=tmp_path)
    assert loaded.path == tmp_path.resolve() / PYTHON_SCENE
    with pytest.raises(InputError, match=os.fspath(PYTHON_SCENE)):
        scene_from({"colour": 1}, base_dir=tmp_path)
