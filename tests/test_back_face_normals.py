"""A double-sided surface's back face shades with its front's mapped normal reversed whole
(glTF 2.0 material.doubleSided: "The back-face must have its normals reversed";
glsl/material/layers.glsl ``sample_material``).

A normal-mapped fold seen from its two sides is one surface: where the front's mapped
normal is m, the back's is -m. Reversing only the geometric normal before the map is
applied reverses the frame's bitangent (cross(ng, t)) but not its tangent, so the back
showed the map's tilt along t mirrored: the normal of a bump leaning towards +t leaned
towards +t on the back too, and on a cloth's folds, where the back shows, the lit and
unlit sides of every wrinkle swapped.

The scene: tests/gltf_builder.py's 2 x 2 m quad (facing +Z, tangent +x along +u), its
normal map one texel tilted towards +t (and +b), seen whole from 1 m in front and from
1 m behind; the G-buffer's normal is compared with m and -m.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.reference.encoding import oct_decode
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from app.scene.model import Light
from tests.gltf_builder import GltfBuilder

pytestmark = pytest.mark.gl

N = 16
SCENE = """\
[camera]
position = {position}
target = [0.0, 0.0, 0.0]
fov_y = 90.0

[[objects]]
shape = "mesh"
file = "m.glb"
"""
# The tangent-space normal of the map's texel: tilted towards +t by 30 degrees and a
# little towards +b, so that a mirror of either axis shows.
MAPPED = np.array([0.5, 0.2, 0.0])
MAPPED[2] = np.sqrt(1.0 - MAPPED[0] ** 2 - MAPPED[1] ** 2)


def quad_file(tmp_path: Path) -> None:
    b = GltfBuilder()
    texel = np.round((MAPPED + 1.0) * 0.5 * 255.0).astype(np.uint8)
    normal_map = Image.fromarray(np.tile(texel, (4, 4, 1)), "RGB")
    mat = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorFactor=[0.8, 0.8, 0.8, 1.0], metallicFactor=0.0, roughnessFactor=0.5
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=b.texture(normal_map)),
        doubleSided=True,
    )
    b.quad(b.material(mat))
    b.save(tmp_path / "m.glb")


def gbuffer_normals(gl, tmp_path: Path, z: float) -> np.ndarray:
    """The G-buffer's world normals, (N*N, 3), seen from (0, 0, ``z``)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(position=[0.0, 0.0, z]), encoding="utf-8")
    r = Renderer(gl, load_scene(scene), (N, N))
    try:
        r.set_lights([Light(type="point", position=[0.0, 0.0, 1.5 * z], intensity=2.0)])
        r.render()
        g = r.read_gbuffer()
    finally:
        r.release()
    assert g.covered.all()
    return oct_decode(g.normal[..., :2].reshape(-1, 2).astype(np.float64))


def test_the_back_face_s_mapped_normal_is_the_front_s_reversed(gl_egl, tmp_path):
    quad_file(tmp_path)
    # the texel's 8-bit rounding and the map's filtering: a few thousandths
    expected = MAPPED / np.linalg.norm(MAPPED)
    front = gbuffer_normals(gl_egl, tmp_path, 1.0)
    np.testing.assert_allclose(front, np.broadcast_to(expected, front.shape), atol=1e-2)
    back = gbuffer_normals(gl_egl, tmp_path, -1.0)
    np.testing.assert_allclose(back, np.broadcast_to(-expected, back.shape), atol=1e-2)
