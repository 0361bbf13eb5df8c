"""An OBJ's MTL material reaches the G-buffer as glTF's base colour does.

Each test writes an OBJ quad (facing the camera, UV (0, 0) at the bottom left) and its
MTL, renders it on EGL and reads RT0 (linear base colour, metallic) and RT1.z (perceptual
roughness) at the quad's pixels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.common.gbuffer import GBufferData
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.test_gltf import SCENE as GLTF_SCENE
from tests.test_gltf import _srgb_decode

SIZE = (64, 64)
# test_gltf.py's camera and light, with the default f32 G-buffer (Kd is checked to 1e-5).
SCENE = GLTF_SCENE.replace('gbuffer = "f16"', 'gbuffer = "f32"').format(file="quad.obj")
QUAD = """\
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
"""


def _render(gl: GLContext, folder: Path, mtl: str | None) -> GBufferData:
    """The G-buffer of the quad, with ``mtl`` as its quad.mtl (None: no mtllib at all)."""
    header = "" if mtl is None else "mtllib quad.mtl\nusemtl m\n"
    (folder / "quad.obj").write_text(header + QUAD, encoding="utf-8")
    if mtl is not None:
        (folder / "quad.mtl").write_text(mtl, encoding="utf-8")
    (folder / "scene.toml").write_text(SCENE, encoding="utf-8")
    renderer = Renderer(gl, load_scene(folder / "scene.toml"), SIZE)
    try:
        renderer.render()
        return renderer.read_gbuffer()
    finally:
        renderer.release()


def _column(g: GBufferData) -> tuple[np.ndarray, np.ndarray]:
    """RT0 and RT1 at the quarter and three-quarter heights of the quad's middle column."""
    rows = np.nonzero(g.depth[:, SIZE[0] // 2] > 0.0)[0]
    assert len(rows) > 16, "the quad does not cover the middle column"
    picks = [rows[len(rows) // 4], rows[3 * len(rows) // 4]]
    return g.base_color[picks, SIZE[0] // 2], g.normal[picks, SIZE[0] // 2]


def test_kd_pr_pm_reach_the_gbuffer(gl_egl: GLContext, tmp_path: Path) -> None:
    """Kd keeps full precision (0.123 is off trimesh's 8-bit ``diffuse`` grid by 0.2 of a
    step, so a uint8 path fails the 1e-5 tolerance); Pr and Pm are roughness, metallic."""
    g = _render(gl_egl, tmp_path, "newmtl m\nKd 0.123 0.456 0.789\nPr 0.3\nPm 0.7\n")
    base, normal = _column(g)
    np.testing.assert_allclose(base[:, :3], [[0.123, 0.456, 0.789]] * 2, atol=1e-5)
    np.testing.assert_allclose(base[:, 3], 0.7, atol=1e-5)
    np.testing.assert_allclose(normal[:, 2], 0.3, atol=1e-5)


def test_map_kd_is_srgb_times_kd_and_upright(gl_egl: GLContext, tmp_path: Path) -> None:
    """map_Kd multiplies Kd after the sRGB decode, and the top of the image lands on the
    top of the quad (OBJ's V runs up, as the image's rows run down)."""
    top, bottom = (200, 100, 30), (0, 0, 255)
    image = Image.new("RGB", (8, 8), bottom)
    image.paste(top, (0, 0, 8, 4))
    image.save(tmp_path / "kd.png")
    kd = (0.5, 1.0, 0.25)
    g = _render(gl_egl, tmp_path, f"newmtl m\nKd {kd[0]} {kd[1]} {kd[2]}\nmap_Kd kd.png\n")
    base, _ = _column(g)
    want_top = [_srgb_decode(t) * k for t, k in zip(top, kd, strict=True)]
    want_bottom = [_srgb_decode(b) * k for b, k in zip(bottom, kd, strict=True)]
    np.testing.assert_allclose(base[0, :3], want_top, atol=1e-2)  # rows run top down
    np.testing.assert_allclose(base[1, :3], want_bottom, atol=1e-2)


def test_obj_without_mtl_keeps_the_default_material(gl_egl: GLContext, tmp_path: Path) -> None:
    """trimesh makes up a grey material with a white image for an OBJ with UVs and no
    MTL; the project's default (0.8 grey, roughness 0.5) must stay."""
    base, normal = _column(_render(gl_egl, tmp_path, None))
    np.testing.assert_allclose(base[:, :3], 0.8, atol=1e-5)
    np.testing.assert_allclose(normal[:, 2], 0.5, atol=1e-5)


@pytest.mark.parametrize("mtl", ["newmtl m\nKd 0.2 0.4 0.6\n", "newmtl m\nmap_Kd kd.png\n"])
def test_scene_material_overrides_the_mtl(gl_egl: GLContext, tmp_path: Path, mtl: str) -> None:
    Image.new("RGB", (2, 2), (255, 0, 0)).save(tmp_path / "kd.png")
    (tmp_path / "quad.obj").write_text("mtllib quad.mtl\nusemtl m\n" + QUAD, encoding="utf-8")
    (tmp_path / "quad.mtl").write_text(mtl, encoding="utf-8")
    scene = SCENE + 'material = "s"\n\n[materials.s]\nbase_color = [0.1, 0.9, 0.3]\n'
    (tmp_path / "scene.toml").write_text(scene, encoding="utf-8")
    renderer = Renderer(gl_egl, load_scene(tmp_path / "scene.toml"), SIZE)
    try:
        renderer.render()
        base, _ = _column(renderer.read_gbuffer())
    finally:
        renderer.release()
    np.testing.assert_allclose(base[:, :3], [[0.1, 0.9, 0.3]] * 2, atol=1e-5)
