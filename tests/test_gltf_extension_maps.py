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
import pytest
from PIL import Image

from app.render.renderer import Renderer
from app.scene.loader import load_scene
from app.scene.model import Light
from tests.agreement import hdr_and_twin
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
        hdr, ref, g = hdr_and_twin(r, loaded.scene.background)
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


# --- extension textures: per-pixel factors of the row (G-buffer RT6) ---

QUAD_N = 32  # the test quad fills a 90-degree view from 1 m (tests/test_gltf_render.py)
QUAD_SCENE = SCENE.replace("[0.0, 0.0, 3.0]", "[0.0, 0.0, 1.0]").replace("60.0", "90.0")
ON_AXIS = Light(type="point", position=[0.0, 0.0, 1.5], intensity=2.0, range=10.0)
NEAREST = {"magFilter": 9728, "minFilter": 9728}


def halves(left: tuple[int, int, int], right: tuple[int, int, int]) -> Image.Image:
    """A 4 x 4 image: its left two columns ``left``, its right two ``right`` (on the
    quad: u < 0.5 and u > 0.5, split at pixel column QUAD_N / 2)."""
    texels = np.zeros((4, 4, 3), np.uint8)
    texels[:, :2] = left
    texels[:, 2:] = right
    return Image.fromarray(texels)


def render_quad(gl, tmp_path, b: GltfBuilder, extensions: list[str]):
    """(HDR image, the twin's image of its G-buffer, G-buffer) of the quad lit on the axis:
    the scene is symmetric about the YZ plane, so column j mirrors column N - 1 - j."""
    b.doc.extensionsUsed = extensions
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(QUAD_SCENE, encoding="utf-8")
    loaded = load_scene(scene)
    r = Renderer(gl, loaded, (QUAD_N, QUAD_N))
    try:
        r.set_lights([ON_AXIS])
        hdr, ref, g = hdr_and_twin(r, loaded.scene.background)
    finally:
        r.release()
    assert g.covered.all()
    return hdr, ref, g


# specularFactor 0: no base specular lobe, and the base is black, so the image is the
# layer under test alone
NO_BASE = {"KHR_materials_specular": {"specularFactor": 0.0}}


def test_sheen_color_texture_darkens_the_cloth_where_it_is_dark(gl_egl, tmp_path):
    """sheenColorTexture (sRGB) multiplies sheenColorFactor per pixel: dark (40, 40, 40)
    on the quad's left half, white on its right. The left half's sheen is decode(40) =
    0.021 of its mirror pixel's on the right, RT6 holds the decoded texels, and every
    pixel is the twin's. Fails with the texture ignored (both halves alike)."""
    b = GltfBuilder()
    tex = b.texture(halves((40, 40, 40), (255, 255, 255)), NEAREST)
    sheen = {"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 0.5,
             "sheenColorTexture": {"index": tex}}  # fmt: skip
    mat = dielectric({**NO_BASE, "KHR_materials_sheen": sheen})
    b.quad(b.material(mat))
    hdr, ref, g = render_quad(
        gl_egl, tmp_path, b, ["KHR_materials_sheen", "KHR_materials_specular"]
    )
    dark = ((40 / 255 + 0.055) / 1.055) ** 2.4  # the sRGB transfer function
    assert g.layer_maps is not None
    np.testing.assert_allclose(g.layer_maps[:, : QUAD_N // 2, :3], dark, atol=2e-3)
    np.testing.assert_array_equal(g.layer_maps[:, QUAD_N // 2 :], 1.0)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    right = hdr[:, QUAD_N // 2 :]
    left_mirrored = hdr[:, : QUAD_N // 2][:, ::-1]
    lit = right[..., 1] > 1e-3
    assert lit.sum() > 100  # the sheen shows away from the centre
    ratio = left_mirrored[lit] / right[lit]
    assert (ratio < 0.05).all() and (ratio > 0.0).all(), (ratio.min(), ratio.max())


def test_a_blended_part_samples_the_sheen_texture_as_the_deferred_one(gl_egl, tmp_path):
    """The blend pass shades alpha-blended parts forward (no G-buffer): the same quad and
    sheen colour texture as above, alphaMode BLEND at alpha 1, gives the opaque quad's
    image (the forward pass scales the row by the same factors). Fails with the forward
    pass ignoring the texture (its dark half as bright as the white one)."""
    images = []
    for mode in ("OPAQUE", "BLEND"):
        b = GltfBuilder()
        tex = b.texture(halves((40, 40, 40), (255, 255, 255)), NEAREST)
        sheen = {"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 0.5,
                 "sheenColorTexture": {"index": tex}}  # fmt: skip
        mat = dielectric({**NO_BASE, "KHR_materials_sheen": sheen})
        mat.alphaMode = mode
        b.quad(b.material(mat))
        extensions = ["KHR_materials_sheen", "KHR_materials_specular"]
        if mode == "OPAQUE":
            images.append(render_quad(gl_egl, tmp_path, b, extensions)[0])
            continue
        b.doc.extensionsUsed = extensions
        b.save(tmp_path / "m.glb")
        (tmp_path / "scene.toml").write_text(QUAD_SCENE, encoding="utf-8")
        r = Renderer(gl_egl, load_scene(tmp_path / "scene.toml"), (QUAD_N, QUAD_N))
        try:
            assert r.frame.parts[0].layers[0].alpha_mode == "blend"
            r.set_lights([ON_AXIS])
            r.render()
            images.append(r.read_hdr().astype(np.float64))
        finally:
            r.release()
    opaque, blended = images
    assert opaque[:, QUAD_N // 2 :].max() > 1e-3
    np.testing.assert_allclose(blended, opaque, rtol=1e-3, atol=1e-6)


def test_sheen_roughness_texture_scales_the_roughness_per_pixel(gl_egl, tmp_path):
    """sheenRoughnessTexture's A multiplies sheenRoughnessFactor per pixel (RT6's A, the
    row's sheen_roughness_map saying so): A = 51 (0.2) on the quad's left half, 255 on
    its right, factor 1. RT6 holds the texels, every pixel is the twin's, and the halves'
    sheen differs from their mirror pixels. Fails with the texture ignored."""
    b = GltfBuilder()
    texels = np.full((4, 4, 4), 255, np.uint8)
    texels[:, :2, 3] = 51
    tex = b.texture(Image.fromarray(texels, "RGBA"), NEAREST)
    sheen = {"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 1.0,
             "sheenRoughnessTexture": {"index": tex}}  # fmt: skip
    mat = dielectric({**NO_BASE, "KHR_materials_sheen": sheen})
    b.quad(b.material(mat))
    hdr, ref, g = render_quad(
        gl_egl, tmp_path, b, ["KHR_materials_sheen", "KHR_materials_specular"]
    )
    assert g.layer_maps is not None
    np.testing.assert_allclose(g.layer_maps[:, : QUAD_N // 2, 3], 0.2, atol=1e-4)  # float16
    np.testing.assert_array_equal(g.layer_maps[:, QUAD_N // 2 :, 3], 1.0)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    left_mirrored = hdr[:, : QUAD_N // 2][:, ::-1]
    right = hdr[:, QUAD_N // 2 :]
    assert np.abs(left_mirrored - right).max() > 0.1 * right.max() > 0.0


def test_clearcoat_texture_zero_has_no_coat_highlight(gl_egl, tmp_path):
    """clearcoatTexture (R) multiplies clearcoatFactor per pixel: 0 on the quad's left
    half, 1 on its right. Over a black base without a specular lobe the left half is
    black (no coat, no highlight) while its mirror image on the right shows the coat's
    highlight; every pixel is the twin's. Fails with the texture ignored."""
    b = GltfBuilder()
    tex = b.texture(halves((0, 0, 0), (255, 0, 0)), NEAREST)
    coat = {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3,
            "clearcoatTexture": {"index": tex}}  # fmt: skip
    mat = dielectric({**NO_BASE, "KHR_materials_clearcoat": coat})
    b.quad(b.material(mat))
    extensions = ["KHR_materials_clearcoat", "KHR_materials_specular"]
    hdr, ref, g = render_quad(gl_egl, tmp_path, b, extensions)
    assert g.layer_maps is not None
    np.testing.assert_array_equal(g.layer_maps[:, : QUAD_N // 2, 3], 0.0)
    np.testing.assert_array_equal(g.layer_maps[:, QUAD_N // 2 :, 3], 1.0)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    assert hdr[:, : QUAD_N // 2].max() < 1e-6  # no coat: nothing reflects
    assert hdr[:, QUAD_N // 2 :].max() > 0.05  # the coat's highlight


def test_specular_color_texture_tints_the_highlight_per_pixel(gl_egl, tmp_path):
    """specularColorTexture (sRGB) multiplies specularColorFactor per pixel (through RT6,
    the row's specular_color_map saying so): yellow (255, 255, 0) on the quad's left half,
    white on its right. The left half keeps R and G of its mirror pixel on the right and
    has almost no B (only Schlick's (1 - F0)(1 - l.h)^5); every pixel is the twin's.
    Fails with the texture ignored (both halves white)."""
    b = GltfBuilder()
    tex = b.texture(halves((255, 255, 0), (255, 255, 255)), NEAREST)
    spec = {"KHR_materials_specular": {"specularColorTexture": {"index": tex}}}
    b.quad(b.material(dielectric(spec)))
    hdr, ref, g = render_quad(gl_egl, tmp_path, b, ["KHR_materials_specular"])
    assert g.layer_maps is not None
    np.testing.assert_array_equal(
        g.layer_maps[:, : QUAD_N // 2, :3],
        np.broadcast_to([1.0, 1.0, 0.0], (QUAD_N, QUAD_N // 2, 3)),
    )
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    left_mirrored = hdr[:, : QUAD_N // 2][:, ::-1]
    right = hdr[:, QUAD_N // 2 :]
    lit = right[..., 1] > 1e-3
    assert lit.sum() > 100
    np.testing.assert_allclose(left_mirrored[lit][:, :2], right[lit][:, :2], rtol=1e-3)
    assert (left_mirrored[lit][:, 2] < 0.1 * right[lit][:, 2]).all()


def test_specular_texture_alpha_scales_the_f0(gl_egl, tmp_path):
    """specularTexture's A multiplies the dielectric F0 per pixel (the layer's f0 map):
    A = 0 on the quad's left half, 255 on its right, specularFactor 1 at ior 1.5, so
    RT1's F0 is 0 on the left and 0.04 on the right; the image is the twin's (F90 stays
    the factor's: a note says so). Fails with the texture ignored (0.04 everywhere)."""
    b = GltfBuilder()
    texels = np.full((4, 4, 4), 255, np.uint8)
    texels[:, :2, 3] = 0
    tex = b.texture(Image.fromarray(texels, "RGBA"), NEAREST)
    spec = {"KHR_materials_specular": {"specularTexture": {"index": tex}}}
    b.quad(b.material(dielectric(spec)))
    hdr, ref, g = render_quad(gl_egl, tmp_path, b, ["KHR_materials_specular"])
    np.testing.assert_array_equal(g.normal[:, : QUAD_N // 2, 3], 0.0)
    np.testing.assert_allclose(g.normal[:, QUAD_N // 2 :, 3], 0.04, rtol=1e-6)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    assert hdr[:, QUAD_N // 2 :].max() > 10.0 * hdr[:, : QUAD_N // 2].max()


def test_extension_textures_take_texcoord_and_texture_transform(gl_egl, tmp_path):
    """An extension texture reads its texCoord and KHR_texture_transform as a core map
    does: the clear-coat halves texture through an offset of half a turn in u reads the
    coated half on the quad's left; the sheen colour texture on TEXCOORD_1 (u mirrored)
    reads its dark half on the right. Fails with the transform or the UV set ignored."""
    b = GltfBuilder()
    coat_tex = b.texture(halves((0, 0, 0), (255, 0, 0)), NEAREST)
    sheen_tex = b.texture(halves((40, 40, 40), (255, 255, 255)), NEAREST)
    moved = {"KHR_texture_transform": {"offset": [0.5, 0.0]}}
    coat = {"clearcoatFactor": 1.0, "clearcoatTexture": {"index": coat_tex, "extensions": moved}}
    sheen = {"sheenColorFactor": [1.0, 1.0, 1.0],
             "sheenColorTexture": {"index": sheen_tex, "texCoord": 1}}  # fmt: skip
    ext = {**NO_BASE, "KHR_materials_clearcoat": coat, "KHR_materials_sheen": sheen}
    uv1 = np.array([[1, 1], [0, 1], [0, 0], [1, 0]], np.float32)  # QUAD_UV with u mirrored
    b.quad(b.material(dielectric(ext)), uv1=uv1)
    names = ["KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_specular"]
    _, _, g = render_quad(gl_egl, tmp_path, b, [*names, "KHR_texture_transform"])
    f = g.layer_maps
    assert f is not None
    np.testing.assert_array_equal(f[:, : QUAD_N // 2, 3], 1.0)
    np.testing.assert_array_equal(f[:, QUAD_N // 2 :, 3], 0.0)
    np.testing.assert_array_equal(f[:, : QUAD_N // 2, :3], 1.0)
    dark = ((40 / 255 + 0.055) / 1.055) ** 2.4
    np.testing.assert_allclose(f[:, QUAD_N // 2 :, :3], dark, atol=2e-3)


def test_scene_key_specular_color_is_the_gltf_row():
    """A scene file's specular_color gives the row and model the glTF mapping gives
    (SPECULAR_COLOR on only where it is not white); with an exact Fresnel model, which
    takes the index and not an F0, the key is an error."""
    from app.scene.model import Material

    p = Material(f0=0.04, specular_color=[1.0, 1.0, 0.0]).resolve()
    assert p.model.specular_color and p.model.defines()["SPECULAR_COLOR"] == 1
    np.testing.assert_array_equal(p.params.specular_color, [1.0, 1.0, 0.0])
    assert not Material(f0=0.04, specular_color=[1.0, 1.0, 1.0]).resolve().model.specular_color
    with pytest.raises(ValueError, match="specular_color: applies only with fresnel"):
        Material(ior=1.5, fresnel="dielectric", specular_color=[1.0, 0.5, 0.5])
