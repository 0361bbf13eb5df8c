"""``pbs view MODEL.glb``: a click on the model selects the file's own material, the
Material panel shows it (edited as ``objects[0].file_materials."<name>"``), and an edit
of its factors redraws the window as ``pbs render`` renders the edited (and saved)
scene. A real glfw window on a private Xvfb server, as tests/test_viewer.py."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.frame.camera import fit_scene
from app.scene.loader import load_scene
from app.scene.look import Look
from app.scene.model_file import model_document
from app.untrusted.policy import DEFAULT_POLICY
from tests.test_viewer import SIZE, assert_close, headless, window_image

HELMET = Path(__file__).resolve().parent / "assets" / "DamagedHelmet"


@pytest.mark.gl
def test_a_picked_model_file_object_shows_its_material_and_an_edit_redraws(
    xdisplay, gl_egl, tmp_path
):
    """The helmet opened as a model file: a click at the image's centre selects object 0
    and its file material "Material_MR", which the Material panel shows; a base colour
    edit through that key path turns the helmet red in the window, equal within 1/255 to
    the headless render of the saved scene. Fails with the panel's old behaviour (no
    file material shown) or with the override not reaching the loader (no change)."""
    from app.viewer.host import Selection
    from app.viewer.window import Viewer

    folder = tmp_path / "helmet"
    shutil.copytree(HELMET, folder)
    scene, data = model_document(folder / "DamagedHelmet.gltf", DEFAULT_POLICY, Look(), SIZE)
    v = Viewer(scene, SIZE, vsync=False, data=data)
    try:
        v.settle()
        ix, iy, w, h = v.image_rect
        assert v.select_pixel(ix + w / 2, iy + h / 2) == Selection(0, None, "Material_MR")
        v.step(3)
        key = 'objects[0].file_materials."Material_MR"'
        assert v.panels.shown_material == key
        before = window_image(v).astype(np.float64)
        assert v.edit({f"{key}.base_color": [1.0, 0.0, 0.0]})
        after = window_image(v).astype(np.float64)
        assert not v.state.error, v.state.error
        assert v.scene.objects[0].file_materials["Material_MR"].base_color == [1.0, 0.0, 0.0]
        moved = np.abs(after - before).sum(axis=-1) > 8
        assert moved.mean() > 0.05  # the helmet's pixels changed
        # green fell where the helmet is, red did not
        assert after[moved][:, 1].mean() < 0.6 * before[moved][:, 1].mean()
        assert after[moved][:, 0].mean() > 0.8 * before[moved][:, 0].mean()
        v.panels.open_sections = True  # Scene > Materials lists the file's material too
        v.step(2)  # the panels draw the override
        assert v.panels.shown_material == key and not v.state.error
        saved = load_scene(v.save_scene(folder / "helmet-view.toml"))
        assert saved.scene == v.scene
        size = v.framebuffer_size
        assert_close(after.astype(np.uint8), headless(gl_egl, fit_scene(saved, size), size))
    finally:
        v.close()
