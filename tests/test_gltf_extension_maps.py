"""glTF KHR_materials_* colours and textures rendered (real GL, real shaders): a coloured
``specularColorFactor`` tints the highlight (the G-buffer's one F0 times the material
row's ``specular_color``), matching the float64 twin's shading of the same G-buffer.

The files are built with pygltflib (tests/gltf_builder.py): two spheres of radius 0.8 at
x = -1 and x = +1, seen from 3 m on the axis, lit by a point light on the axis, so the
scene is symmetric about the YZ plane and the right sphere's pixels mirror the left's.
"""

from __future__ import annotations

import numpy as np
import pygltflib

from app.reference.illumination import shade_gbuffer
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from app.scene.model import Light
from tests.gltf_builder import GltfBuilder
from tests.test_gltf_render import sphere

N = 48  # image size (pixels)
PBR = pygltflib.PbrMetallicRoughness
LIGHT = Light(type="point", position=[0.0, 0.0, 2.5], intensity=6.0, range=20.0)

SCENE = """\
[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 60.0

[[objects]]
shape = "mesh"
file = "m.glb"
"""


def two_spheres(b: GltfBuilder, left: int, right: int) -> None:
    """Spheres of materials ``left`` (x = -1) and ``right`` (x = +1)."""
    for material, x in ((left, -1.0), (right, 1.0)):
        node = sphere(b, material, rings=24, segments=48)
        b.doc.nodes[node].translation = [x, 0.0, 0.0]


def render_with_twin(gl, tmp_path, b: GltfBuilder, extensions: list[str]):
    """(HDR image, the twin's image of the same G-buffer, covered pixels) of ``b``'s file."""
    b.doc.extensionsUsed = extensions
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE, encoding="utf-8")
    loaded = load_scene(scene)
    r = Renderer(gl, loaded, (N, N))
    try:
        r.set_lights([LIGHT])
        r.render()
        hdr = r.read_hdr().astype(np.float64)
        g = r.read_gbuffer()
        ref = shade_gbuffer(
            g, r.camera, r.lights, loaded.scene.background, r.materials.models,
            r.materials.packed(),
        )  # fmt: skip
    finally:
        r.release()
    return hdr, ref, g.covered


def dielectric(extensions: dict | None = None) -> pygltflib.Material:
    """A black dielectric (the image is its specular reflection alone), roughness 0.3."""
    pbr = PBR(baseColorFactor=[0.0, 0.0, 0.0, 1.0], metallicFactor=0.0, roughnessFactor=0.3)
    return pygltflib.Material(pbrMetallicRoughness=pbr, extensions=extensions)


def test_yellow_specular_color_tints_the_highlight_as_the_twin(gl_egl, tmp_path):
    """specularColorFactor (1, 1, 0) beside (1, 1, 1), both specularFactor 0.8 (F90 0.8:
    the generalised Schlick): F0 = (0.032, 0.032, 0) against 0.032 in every channel. On
    the untinted sphere's highlight the yellow one keeps R and G and loses almost all of
    B (only Schlick's (F90 - F0)(1 - l.h)^5 is left there); every pixel is the twin's.
    Fails where the coloured F0 is reduced to one number (its luminance, or any grey)
    and where the lighting pass drops the row's specular_color (material_F0)."""
    b = GltfBuilder()
    white = {"KHR_materials_specular": {"specularFactor": 0.8}}
    yellow = {"KHR_materials_specular": {"specularFactor": 0.8, "specularColorFactor": [1, 1, 0]}}
    two_spheres(b, b.material(dielectric(white)), b.material(dielectric(yellow)))
    hdr, ref, covered = render_with_twin(gl_egl, tmp_path, b, ["KHR_materials_specular"])
    np.testing.assert_allclose(hdr[covered], ref[covered], rtol=2e-3, atol=2e-5)
    left = covered.copy()
    left[:, N // 2 :] = False
    assert left.sum() > 200 and np.array_equal(left[:, ::-1], covered & ~left)
    untinted = hdr[left]
    tinted = hdr[:, ::-1][left]  # the yellow sphere, column-mirrored onto the left one
    highlight = untinted[:, 1] > 0.05  # the untinted sphere's highlight
    assert highlight.sum() >= 8
    # R and G: the same F0 (0.032) on both spheres
    np.testing.assert_allclose(tinted[highlight, :2], untinted[highlight, :2], rtol=1e-3)
    # B: F0 = 0, so a small part of the untinted sphere's
    assert (tinted[highlight, 2] < 0.1 * untinted[highlight, 2]).all()
    assert (tinted[highlight, 0] > 10.0 * tinted[highlight, 2]).all()
