"""``pbs gallery`` (app/gallery.py): a folder of sample models in the Khronos layout ->
one contact sheet, each model rendered beside its reference screenshot; a bad model is one
line, exit 2, and no sheet. The models are tests/assets/gallery/ (two small Khronos test
models, tests/assets/gallery/LICENSE.md)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from app.errors import EXIT_BAD_INPUT
from app.gallery import (
    BACKDROP,
    GUTTER,
    REFERENCE_EXPOSURE,
    GalleryModel,
    find_models,
    letterbox,
    posed_look,
    read_reference,
    reference_look,
    render_model,
)
from app.render.renderer import Renderer
from app.scene.look import Look
from app.scene.sources import scene_from

ASSETS = Path(__file__).resolve().parent / "assets" / "gallery"
NAMES = ["TextureCoordinateTest", "TextureSettingsTest"]
SIZE = 48


def test_the_khronos_layout_is_found():
    models = find_models(ASSETS)
    assert [m.name for m in models] == NAMES
    for m in models:
        assert m.model.suffix == ".glb" and m.model.parent.name == "glTF-Binary"
        assert m.reference is not None and m.reference.name == "screenshot.png"


def test_a_time_poses_the_animated_models_and_leaves_the_rest_at_rest():
    # `pbs gallery --time 1` over a folder of mixed models: `pbs render` refuses a time for
    # a file without animations, the gallery poses only the ones that have them.
    walk = Look(time=1.0)
    cesium = GalleryModel("CesiumMan", ASSETS.parent / "CesiumMan.glb", None)
    assert posed_look(cesium, walk) == walk
    for still in find_models(ASSETS):
        assert posed_look(still, walk) == Look()
        assert posed_look(still, Look(variant="x")) == Look(variant="x")


@pytest.mark.gl
def test_the_sheet_holds_a_render_and_its_reference_per_model(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    code = main(["gallery", str(ASSETS), "-o", str(out), "--size", str(SIZE), "--columns", "2"])
    assert code == 0, capsys.readouterr().err
    assert "2 models (2 with a reference)" in capsys.readouterr().out
    sheet = np.asarray(Image.open(out).convert("RGB")).astype(np.int32)
    cell = 2 * SIZE + GUTTER
    assert sheet.shape[1] == 2 * cell + GUTTER  # two cells side by side
    for k in range(2):
        x = k * (cell + GUTTER)
        rendered = sheet[:SIZE, x : x + SIZE]
        reference = sheet[:SIZE, x + SIZE + GUTTER : x + cell]
        # each panel has content, not the empty backdrop: the model covers pixels and
        # the reference (both mostly saturated colours on blue or grey) was pasted in
        for panel in (rendered, reference):
            assert np.abs(panel - np.array(BACKDROP)).sum(axis=-1).mean() > 40
            assert panel.std() > 20
        # the reference panel is the screenshot, letterboxed into the square
        shot = letterbox(read_reference(find_models(ASSETS)[k].reference), SIZE)
        np.testing.assert_array_equal(reference, shot)
    assert sheet[SIZE + 2 :].std() > 10  # the label bands under the pairs hold text


@pytest.mark.gl
def test_a_bad_model_is_one_line_exit_2_and_no_sheet(tmp_path, capsys):
    folder = tmp_path / "models"
    shutil.copytree(ASSETS / NAMES[0], folder / NAMES[0])
    broken = folder / "Broken" / "glTF-Binary" / "Broken.glb"
    broken.parent.mkdir(parents=True)
    broken.write_bytes(b"glTF\x02\x00\x00\x00" + b"\x00" * 12)
    out = tmp_path / "sheet.png"
    code = main(["gallery", str(folder), "-o", str(out), "--size", str(SIZE)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == EXIT_BAD_INPUT
    assert len(err) == 1 and "Broken.glb" in err[0], err
    assert not out.exists()


def test_a_folder_without_models_is_refused(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    assert main(["gallery", str(tmp_path), "-o", str(out)]) == EXIT_BAD_INPUT
    assert "holds no .gltf/.glb model" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.gl
def test_the_gallery_shows_models_in_the_reference_viewers_look(gl_egl):
    """The gallery's look (docs/gltf.md, "Conformance gallery"): a model without lights is
    shown without the default look's key and fill lights and at the fixed
    ``REFERENCE_EXPOSURE`` instead of the metered one, as the glTF Sample Viewer shows its
    screenshots (image-based light only, a fixed exposure). Fails with the default look
    (``pbs render MODEL``'s) rendered as it is."""
    model = find_models(ASSETS)[0]
    look = Look("front")
    default = scene_from(model.model, look=look, size=(SIZE, SIZE))
    gallery = reference_look(default, look)
    assert len(default.scene.lights) == 2  # the default look's key and fill
    assert default.scene.camera.exposure != REFERENCE_EXPOSURE  # metered
    assert gallery.scene.lights == [] and gallery.scene.camera.exposure == REFERENCE_EXPOSURE

    def shown(loaded):
        renderer = Renderer(gl_egl, loaded, (SIZE, SIZE))
        try:
            renderer.render()
            return renderer.read_ldr()[..., :3]
        finally:
            renderer.release()

    rendered, covered = render_model(gl_egl, model, SIZE, look)
    assert covered
    np.testing.assert_array_equal(rendered, shown(reference_look(default, look)))
    assert np.abs(rendered.astype(int) - shown(default).astype(int)).max() > 20
