"""A model object's ``file_materials``: the scene overrides a glTF file's own material
factors where the loader reads them (app/scene/gltf.py, app/scene/file_materials.py).

An override must render exactly as the same factors written in the file would, maps
included (a roughness factor is baked into the normal/roughness chain with the file's
metallic-roughness texture); a name the file lacks, an unknown key, or the key beside
``material`` is one line naming the scene file and the key, exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.cli import main
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.gltf_builder import GltfBuilder, png_rgb
from tests.test_gltf_render import EXTRA_NODE_X, ON_AXIS, N, frame

PBR = pygltflib.PbrMetallicRoughness
# The factors the right quad's material "paint" is given, in the file or by the scene.
PAINT = {
    "base_color": [0.3, 0.6, 0.1],
    "alpha": 1.0,
    "metallic": 0.5,
    "roughness": 0.25,
    "emissive": [0.2, 0.1, 0.0],
    "emissive_strength": 2.0,
}
SCENE = """\
[camera]
position = [0.0, 0.0, 2.0]
target = [0.0, 0.0, 0.0]
fov_y = 90.0

[[objects]]
shape = "mesh"
file = "m.glb"
{extra}
"""


def two_quads(path: Path, paint_in_file: bool) -> None:
    """Quads "plain" (left) and "paint" (right), both with the same metallic-roughness
    texture; "paint" has ``PAINT``'s factors where ``paint_in_file``, else plain's."""
    b = GltfBuilder()
    texture = b.texture(png_rgb((0, 200, 128)))  # roughness 200/255, metalness 128/255
    info = pygltflib.TextureInfo(index=texture)

    def material(name: str, paint: bool) -> int:
        pbr = PBR(baseColorFactor=[0.8, 0.8, 0.8, 1.0], metallicFactor=0.0,
                  roughnessFactor=1.0, metallicRoughnessTexture=info)  # fmt: skip
        extra: dict = {}
        if paint:
            pbr.baseColorFactor = [*PAINT["base_color"], PAINT["alpha"]]
            pbr.metallicFactor, pbr.roughnessFactor = PAINT["metallic"], PAINT["roughness"]
            extra = {
                "emissiveFactor": PAINT["emissive"],
                "extensions": {
                    "KHR_materials_emissive_strength": {
                        "emissiveStrength": PAINT["emissive_strength"]
                    }
                },
            }
        return b.material(pygltflib.Material(name=name, pbrMetallicRoughness=pbr, **extra))

    plain, paint = material("plain", False), material("paint", paint_in_file)
    b.quad(plain, translation=[-EXTRA_NODE_X, 0.0, 0.0])
    b.quad(paint, translation=[EXTRA_NODE_X, 0.0, 0.0])
    b.save(path)


def render(gl, folder: Path, paint_in_file: bool, extra: str = "") -> np.ndarray:
    """The HDR image of the two quads lit on the axis."""
    folder.mkdir()
    two_quads(folder / "m.glb", paint_in_file)
    scene = folder / "scene.toml"
    scene.write_text(SCENE.format(extra=extra), encoding="utf-8")
    r = Renderer(gl, load_scene(scene), (N, N))
    try:
        r.set_lights([ON_AXIS])
        return frame(r)[0]
    finally:
        r.release()


def inline(table: dict) -> str:
    return "{ " + ", ".join(f"{k} = {v}" for k, v in table.items()) + " }"


@pytest.mark.gl
def test_an_override_renders_as_the_factors_written_in_the_file(gl_egl, tmp_path):
    """The scene's ``file_materials.paint`` on a file whose "paint" has plain's factors
    renders bit for bit as the file with ``PAINT``'s factors written in, and differs from
    the file without the override. Fails with the override ignored (the image is the
    unpainted one) or applied to the wrong material (the left quad changes)."""
    written = render(gl_egl, tmp_path / "written", paint_in_file=True)
    unpainted = render(gl_egl, tmp_path / "unpainted", paint_in_file=False)
    over = f"file_materials = {{ paint = {inline(PAINT)} }}"
    overridden = render(gl_egl, tmp_path / "overridden", paint_in_file=False, extra=over)
    right = np.zeros(written.shape[:2], bool)
    right[:, N // 2 + 1 :] = True
    assert np.abs(written - unpainted)[right].max() > 0.05  # the factors show
    np.testing.assert_array_equal(overridden, written)


BAD = [
    ('file_materials = { nope = { roughness = 0.5 } }', 'objects[0].file_materials."nope"'),
    ("file_materials = { paint = { roughnes = 0.5 } }", "objects[0].file_materials.paint.roughnes"),
    ("file_materials = { paint = { metallic = 1.5 } }", "objects[0].file_materials.paint.metallic"),
    ('material = "m"\nfile_materials = { paint = { metallic = 0.5 } }',
     "objects[0].file_materials"),
]  # fmt: skip


@pytest.mark.parametrize(("extra", "key"), BAD)
def test_a_bad_override_is_one_line_naming_file_and_key(tmp_path, capsys, extra, key):
    """A material the file lacks, an unknown key, a value out of range, and the key beside
    ``material``: exit 2, one line naming the scene file and the key, no image."""
    two_quads(tmp_path / "m.glb", paint_in_file=False)
    scene = tmp_path / "scene.toml"
    materials = '\n[materials.m]\npreset = "gold"\n' if "material =" in extra else ""
    scene.write_text(SCENE.format(extra=extra) + materials, encoding="utf-8")
    out = tmp_path / "out.png"
    assert main(["render", str(scene), "-o", str(out), "--size", "16x16"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert str(scene) in err and f"{key}:" in err, err
    assert not out.exists()


@pytest.mark.parametrize("strength", [None, "x", [1], float("nan")])
def test_own_factors_of_an_unchecked_material_fall_back_to_the_defaults(strength) -> None:
    """The viewer lists every material of a file, also one no primitive uses, which the
    reader never checks: a factor that is not a finite number reads as glTF's default
    instead of raising inside the panel's frame."""
    from app.scene.file_materials import own_factors

    material = pygltflib.Material(
        name="unused",
        pbrMetallicRoughness=PBR(baseColorFactor=[0.5, "a", 0.5, 1.0], metallicFactor=None),
        emissiveFactor=[1.0, 0.5],
        extensions={"KHR_materials_emissive_strength": {"emissiveStrength": strength}},
    )
    factors = own_factors(material)
    assert factors["base_color"] == [1.0, 1.0, 1.0] and factors["alpha"] == 1.0
    assert factors["metallic"] == 1.0 and factors["emissive"] == [0.0, 0.0, 0.0]
    assert factors["emissive_strength"] == 1.0


def test_a_missing_material_key_is_quoted_as_toml_writes_it(tmp_path: Path) -> None:
    """A scene key holding a quote is named escaped, so the line shows the key written."""
    from app.errors import InputError
    from app.scene.file_materials import resolved

    materials = [pygltflib.Material(name=f"m{i}") for i in range(12)]
    with pytest.raises(InputError) as caught:
        resolved({'pa"int': object()}, materials, "scene.toml", 0, "m.glb")  # type: ignore[dict-item]
    text = str(caught.value)
    assert 'objects[0].file_materials."pa\\"int"' in text
    assert '"m7", ... 4 more' in text and '"m8"' not in text
