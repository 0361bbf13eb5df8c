"""Mesh files written by trimesh reach the G-buffer: glTF metallic-roughness materials
(read by the project's reader, app/scene/gltf.py) and PLY/STL with the default material.

Each test writes a tiny mesh file with trimesh, a scene TOML that places it in front of
the camera, renders it on EGL and reads the G-buffer back: RT0 holds base_color.rgb
(linear) and metallic, RT1.z the perceptual roughness, RT1.w the dielectric F0.

trimesh keeps ``PBRMaterial.baseColorFactor`` as uint8 (0-255), so the factor it
*writes* is already on the 8-bit grid; the exact-match tests use factors of the form
k/255. (The reader keeps factors at full precision: tests/test_gltf_reader.py.)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from app.gl.context import GLContext
from app.render.gbuffer import GBufferData
from app.render.renderer import Renderer
from app.scene.loader import load_scene

SIZE = (64, 64)
F16_TOL = 1e-3  # float16 G-buffer: relative step 2^-11 near 1.0

SCENE = """\
[render]
gbuffer = "f16"

[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 45.0

[[lights]]
type = "directional"
direction = [0.0, 0.0, -1.0]

[[objects]]
shape = "mesh"
file = "{file}"
"""


def _srgb_decode(c: float) -> float:
    """An 8-bit sRGB code value -> linear (the piecewise sRGB EOTF)."""
    x = c / 255.0
    return x / 12.92 if x <= 0.04045 else ((x + 0.055) / 1.055) ** 2.4


def _box(material: trimesh.visual.material.PBRMaterial, uv: bool = False) -> trimesh.Trimesh:
    """A unit box; with ``uv`` every corner samples the middle of the texture."""
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    mesh.unmerge_vertices()  # one vertex per face corner, as a textured mesh would have
    coords = np.full((len(mesh.vertices), 2), 0.5) if uv else None
    mesh.visual = trimesh.visual.TextureVisuals(uv=coords, material=material)
    return mesh


def _quad(material: trimesh.visual.material.PBRMaterial) -> trimesh.Trimesh:
    """A 2 x 2 quad in the XY plane facing +Z, UV (0, 0) at the bottom left."""
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float64)
    mesh = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    return mesh


def _render(gl: GLContext, tmp_path: Path, mesh: trimesh.Trimesh, name: str, extra: str = ""):
    """Export ``mesh`` as ``name``, render a scene holding it, return its G-buffer."""
    mesh.export(tmp_path / name, file_type=Path(name).suffix[1:])
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file=name) + extra)
    renderer = Renderer(gl, load_scene(scene), SIZE)
    try:
        renderer.render()
        return renderer.read_gbuffer()
    finally:
        renderer.release()


def _centre(g: GBufferData) -> tuple[np.ndarray, np.ndarray, float]:
    h, w = g.depth.shape
    assert g.depth[h // 2, w // 2] > 0.0, "the mesh does not cover the centre pixel"
    return g.base_color[h // 2, w // 2], g.normal[h // 2, w // 2], float(g.depth[h // 2, w // 2])


def test_trimesh_quantises_base_color_factor_to_uint8() -> None:
    """The premise of the k/255 factors below (if trimesh changes, revisit the tolerances)."""
    mat = trimesh.visual.material.PBRMaterial(baseColorFactor=[0.5, 0.2, 1.0, 1.0])
    factor = np.asarray(mat.baseColorFactor)
    assert factor.dtype == np.uint8
    np.testing.assert_array_equal(factor, [128, 51, 255, 255])


@pytest.mark.parametrize(
    ("rgb255", "metallic", "roughness"),
    [((51, 128, 204), 0.3, 0.7), ((230, 25, 140), 1.0, 0.15), ((255, 255, 255), 0.0, 1.0)],
)
def test_glb_factors_reach_gbuffer(
    gl_egl: GLContext,
    tmp_path: Path,
    rgb255: tuple[int, int, int],
    metallic: float,
    roughness: float,
) -> None:
    base = [c / 255.0 for c in rgb255]
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[*base, 1.0], metallicFactor=metallic, roughnessFactor=roughness
    )
    g = _render(gl_egl, tmp_path, _box(material), "thing.glb")
    albedo, normal, depth = _centre(g)
    np.testing.assert_allclose(albedo[:3], base, atol=F16_TOL)
    assert albedo[3] == pytest.approx(metallic, abs=F16_TOL)
    assert normal[2] == pytest.approx(roughness, abs=F16_TOL)
    assert normal[3] == pytest.approx(0.04, abs=F16_TOL)  # glTF has no F0: the default
    assert depth == pytest.approx(2.5, abs=1e-3)  # the box's front face, 2.5 m away


def test_glb_factor_off_the_8bit_grid_is_within_half_a_step(
    gl_egl: GLContext, tmp_path: Path
) -> None:
    """0.5 becomes 128/255 in trimesh: off by at most half an 8-bit step."""
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[0.5, 0.25, 0.75, 1.0], metallicFactor=0.0, roughnessFactor=0.5
    )
    albedo, _, _ = _centre(_render(gl_egl, tmp_path, _box(material), "thing.glb"))
    np.testing.assert_allclose(albedo[:3], [0.5, 0.25, 0.75], atol=0.5 / 255 + F16_TOL)


@pytest.mark.parametrize("factor255", [(255, 255, 255), (255, 128, 51)])
def test_glb_base_color_texture_is_srgb_decoded_times_factor(
    gl_egl: GLContext, tmp_path: Path, factor255: tuple[int, int, int]
) -> None:
    texel = (200, 100, 30)
    factor = [c / 255.0 for c in factor255]
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[*factor, 1.0],
        baseColorTexture=Image.new("RGB", (4, 4), texel),
        metallicFactor=0.0,
        roughnessFactor=0.5,
    )
    albedo, _, _ = _centre(_render(gl_egl, tmp_path, _box(material, uv=True), "thing.glb"))
    want = [_srgb_decode(t) * f for t, f in zip(texel, factor, strict=True)]
    np.testing.assert_allclose(albedo[:3], want, atol=1e-2)
    # Not the raw (sRGB-encoded) code values: the decode really happened.
    assert abs(albedo[0] - texel[0] / 255.0 * factor[0]) > 0.15


def test_glb_texture_orientation(gl_egl: GLContext, tmp_path: Path) -> None:
    """The top of the image lands on the top of the quad (glTF's V flip is undone once)."""
    top, bottom = (255, 0, 0), (0, 0, 255)
    image = Image.new("RGB", (8, 8), bottom)
    image.paste(top, (0, 0, 8, 4))  # rows 0-3 (the top half of the picture)
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[1.0, 1.0, 1.0, 1.0], baseColorTexture=image
    )
    g = _render(gl_egl, tmp_path, _quad(material), "quad.glb")
    rows = np.nonzero(g.depth[:, SIZE[0] // 2] > 0.0)[0]
    assert len(rows) > 16
    upper = g.base_color[rows[len(rows) // 4], SIZE[0] // 2, :3]
    lower = g.base_color[rows[3 * len(rows) // 4], SIZE[0] // 2, :3]
    np.testing.assert_allclose(upper, [1.0, 0.0, 0.0], atol=1e-2)
    np.testing.assert_allclose(lower, [0.0, 0.0, 1.0], atol=1e-2)


def test_glb_metallic_roughness_texture(gl_egl: GLContext, tmp_path: Path) -> None:
    """glTF: roughness = factor x G, metallic = factor x B, both linear (no sRGB decode)."""
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[0.6, 0.6, 0.6, 1.0],
        metallicRoughnessTexture=Image.new("RGB", (4, 4), (0, 128, 64)),
        metallicFactor=1.0,
        roughnessFactor=0.5,
    )
    albedo, normal, _ = _centre(_render(gl_egl, tmp_path, _box(material, uv=True), "thing.glb"))
    assert albedo[3] == pytest.approx(64 / 255, abs=5e-3)
    assert normal[2] == pytest.approx(0.5 * 128 / 255, abs=5e-3)


def test_scene_material_overrides_file_material(gl_egl: GLContext, tmp_path: Path) -> None:
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[1.0, 0.2, 0.2, 1.0],
        baseColorTexture=Image.new("RGB", (4, 4), (200, 100, 30)),
        metallicFactor=1.0,
        roughnessFactor=0.9,
    )
    extra = (
        'material = "mine"\n\n'
        "[materials.mine]\n"
        "base_color = [0.1, 0.9, 0.3]\nmetallic = 0.0\nroughness = 0.25\nf0 = 0.08\n"
    )
    g = _render(gl_egl, tmp_path, _box(material, uv=True), "thing.glb", extra)
    albedo, normal, _ = _centre(g)
    # The texture is dropped too: the scene's colour comes through unmodulated.
    np.testing.assert_allclose(albedo[:3], [0.1, 0.9, 0.3], atol=F16_TOL)
    assert albedo[3] == pytest.approx(0.0, abs=F16_TOL)
    assert normal[2] == pytest.approx(0.25, abs=F16_TOL)
    assert normal[3] == pytest.approx(0.08, abs=F16_TOL)


@pytest.mark.parametrize("name", ["thing.ply", "thing.stl"])
def test_ply_and_stl_render_with_the_default_material(
    gl_egl: GLContext, tmp_path: Path, name: str
) -> None:
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[0.2, 0.5, 0.8, 1.0], metallicFactor=0.3, roughnessFactor=0.7
    )
    g = _render(gl_egl, tmp_path, _box(material), name)
    albedo, normal, depth = _centre(g)
    # Neither format carries a PBR material: the documented grey-plastic default.
    np.testing.assert_allclose(albedo[:3], [0.8, 0.8, 0.8], atol=F16_TOL)
    assert albedo[3] == pytest.approx(0.0, abs=F16_TOL)
    assert normal[2] == pytest.approx(0.5, abs=F16_TOL)
    assert depth == pytest.approx(2.5, abs=1e-3)
