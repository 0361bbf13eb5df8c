"""An OBJ's MTL material reaches the G-buffer as glTF's material does.

Each test writes an OBJ quad (facing the camera, UV (0, 0) at the bottom left) and its
MTL, and either reads the SurfaceLayer it becomes (``build_parts``) or renders it on EGL
and reads RT0 (linear base colour, metallic), RT1 (octahedral normal, perceptual
roughness) and RT5 (emission) at the quad's pixels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.common.gbuffer import GBufferData
from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.render.renderer import Renderer
from app.scene.geometry import build_parts
from app.scene.loader import load_scene
from app.scene.references import parse_map_statement
from app.textures.maps import SurfaceLayer
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


def _write(folder: Path, mtl: str | None) -> Path:
    """The quad's OBJ, ``mtl`` as its quad.mtl (None: no mtllib at all) and the scene."""
    header = "" if mtl is None else "mtllib quad.mtl\nusemtl m\n"
    (folder / "quad.obj").write_text(header + QUAD, encoding="utf-8")
    if mtl is not None:
        (folder / "quad.mtl").write_text(mtl, encoding="utf-8")
    (folder / "scene.toml").write_text(SCENE, encoding="utf-8")
    return folder / "scene.toml"


def _layer(folder: Path, mtl: str) -> SurfaceLayer:
    """The SurfaceLayer the quad's MTL material becomes."""
    (part,) = build_parts(load_scene(_write(folder, mtl)))
    return part.layers[0]


def _render(gl: GLContext, folder: Path, mtl: str | None) -> GBufferData:
    """The G-buffer of the quad, with ``mtl`` as its quad.mtl (None: no mtllib at all)."""
    _write(folder, mtl)
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


# A normal-map texel tilted 30 degrees from +z towards +u (the quad's +x), 8-bit.
TILT = np.radians(30.0)
TILTED = (np.sin(TILT), 0.0, np.cos(TILT))
TILTED_RGB = tuple(int(c) for c in np.round((np.array(TILTED) * 0.5 + 0.5) * 255))


def _pbr_maps(folder: Path) -> None:
    """One-colour maps for the PBR MTL statements (a file name with a space included)."""
    Image.new("RGB", (4, 4), (0, 102, 0)).save(folder / "rough.png")  # R = 0: not G
    Image.new("RGB", (4, 4), (153, 0, 0)).save(folder / "metal.png")
    Image.new("RGB", (4, 4), TILTED_RGB).save(folder / "my normal.png")
    Image.new("RGB", (4, 4), (255, 128, 0)).save(folder / "glow.png")
    Image.new("L", (2, 2), 64).save(folder / "cover.png")
    Image.new("RGB", (4, 4), (10, 20, 30)).save(folder / "kd.png")


def test_pbr_maps_reach_the_layer_exactly(tmp_path: Path) -> None:
    """Each map reaches the SurfaceLayer with its factor: map_Pr (R, linear) times Pr in
    the chain's alpha, map_Pm as the metallic map with Pm the factor, norm's texels scaled
    by -bm in x and y (a name with a space after the option), Ke / map_Ke the emission,
    d the alpha in blend mode and map_d the base colour texture's alpha (resampled to
    map_Kd's size); map_Kd behind an -s option is read (trimesh dropped it)."""
    _pbr_maps(tmp_path)
    mtl = (
        "newmtl m\nKd 1 1 1\nPr 0.5\nPm 0.25\nmap_Pr rough.png\nmap_Pm metal.png\n"
        "norm -bm 0.5 my normal.png\nKe 2 3 4\nmap_Ke glow.png\nd 0.75\nmap_d cover.png\n"
        "map_Kd -s 1 1 1 kd.png\n"
    )
    layer = _layer(tmp_path, mtl)
    assert (layer.params.roughness, layer.params.metallic) == (0.5, 0.25)
    assert layer.maps["metallic"].pixels[0, 0, 0] == pytest.approx(153 / 255)
    chain = layer.maps["normal_roughness"].pixels[0, 0]
    assert chain[3] == pytest.approx(0.5 * 0.0, abs=1e-7)  # R of rough.png is 0
    raw = np.array(TILTED_RGB) / 255.0 * 2.0 - 1.0
    want = raw * [0.5, 0.5, 1.0]
    np.testing.assert_allclose(chain[:3], want / np.linalg.norm(want), atol=2e-3)
    assert layer.normal_mapped
    assert layer.emissive == (2.0, 3.0, 4.0)
    np.testing.assert_array_equal(layer.maps["emissive"].pixels[0, 0], [255, 128, 0, 255])
    assert (layer.alpha, layer.alpha_mode) == (0.75, "blend")
    np.testing.assert_array_equal(layer.maps["base_color"].pixels.shape, (4, 4, 4))
    np.testing.assert_array_equal(layer.maps["base_color"].pixels[0, 0], [10, 20, 30, 64])


def test_a_map_without_its_factor_has_factor_one(tmp_path: Path) -> None:
    """map_Pr, map_Pm, map_Ke without Pr, Pm, Ke: the map alone (as map_Kd without Kd);
    map_d alone: white RGB at its size, blend; no d or map_d: opaque."""
    _pbr_maps(tmp_path)
    (tmp_path / "rough.png").unlink()
    Image.new("RGB", (4, 4), (102, 0, 0)).save(tmp_path / "rough.png")
    layer = _layer(
        tmp_path, "newmtl m\nmap_Pr rough.png\nmap_Pm metal.png\nmap_Ke glow.png\nmap_d cover.png\n"
    )
    assert (layer.params.roughness, layer.params.metallic) == (1.0, 1.0)
    assert layer.maps["normal_roughness"].pixels[0, 0, 3] == pytest.approx(102 / 255)
    assert not layer.normal_mapped  # a roughness map alone keeps the normals flat
    assert layer.emissive == (1.0, 1.0, 1.0)
    assert layer.alpha_mode == "blend"
    np.testing.assert_array_equal(layer.maps["base_color"].pixels[0, 0], [255, 255, 255, 64])
    plain = _layer(tmp_path, "newmtl m\nKd 0.5 0.5 0.5\n")
    assert (plain.alpha, plain.alpha_mode, plain.emissive) == (1.0, "opaque", (0.0, 0.0, 0.0))
    assert not plain.maps


def test_pbr_maps_render(gl_egl: GLContext, tmp_path: Path) -> None:
    """Rendered: norm tilts the G-buffer normal 30 degrees towards +x (the quad's +u);
    map_Pr x Pr is the G-buffer roughness, map_Pm x Pm its metallic, Ke x map_Ke (sRGB)
    its emission."""
    _pbr_maps(tmp_path)
    Image.new("RGB", (4, 4), (102, 0, 0)).save(tmp_path / "rough.png")
    mtl = (
        "newmtl m\nKd 1 1 1\nPr 0.5\nPm 0.5\nmap_Pr rough.png\nmap_Pm metal.png\n"
        "norm my normal.png\nKe 2 1 0.5\nmap_Ke glow.png\n"
    )
    g = _render(gl_egl, tmp_path, mtl)
    base, normal = _column(g)
    # The maps are stored as float16 (spacing 2.4e-4 near 0.3).
    np.testing.assert_allclose(base[:, 3], 0.5 * 153 / 255, atol=5e-4)
    np.testing.assert_allclose(normal[:, 2], 0.5 * 102 / 255, atol=5e-4)
    for row in normal:
        got = oct_decode(row[:2].astype(np.float64))
        assert np.degrees(np.arccos(np.clip(got @ np.array(TILTED), -1, 1))) < 0.5, got
    assert g.emission is not None
    mid = SIZE[1] // 2, SIZE[0] // 2
    want = [2.0 * _srgb_decode(255), 1.0 * _srgb_decode(128), 0.0]
    np.testing.assert_allclose(g.emission[mid][:3], want, atol=1e-2)


def test_dissolve_takes_the_blend_pass(gl_egl: GLContext, tmp_path: Path) -> None:
    """d 0.5: the quad leaves the G-buffer (blended parts are shaded forward after
    lighting) and its HDR pixel is half of d 1's over half of the background (d 0)."""
    hdr = {}
    for d in (0.0, 0.5, 1.0):
        _write(tmp_path, f"newmtl m\nKd 1 1 1\nd {d}\n")
        renderer = Renderer(gl_egl, load_scene(tmp_path / "scene.toml"), SIZE)
        try:
            renderer.render()
            covered = renderer.read_gbuffer().covered[SIZE[1] // 2, SIZE[0] // 2]
            hdr[d] = renderer.read_hdr()[SIZE[1] // 2, SIZE[0] // 2, :3].astype(np.float64)
        finally:
            renderer.release()
        assert covered == (d == 1.0), d
    assert hdr[1.0].min() > hdr[0.0].max() + 0.1, hdr  # the lit quad stands out
    np.testing.assert_allclose(hdr[0.5], 0.5 * hdr[1.0] + 0.5 * hdr[0.0], rtol=1e-2, atol=1e-3)


@pytest.mark.parametrize(
    ("rest", "options", "name"),
    [
        (" kd.png", {}, "kd.png"),
        (" -s 1 1 1 my kd.png", {"-s": ("1", "1", "1")}, "my kd.png"),
        (" -o 0.5 0.25 -bm 2 n.png", {"-o": ("0.5", "0.25"), "-bm": ("2",)}, "n.png"),
        (" -clamp on -imfchan r 1.png", {"-clamp": ("on",), "-imfchan": ("r",)}, "1.png"),
        (" -s 2 2.png", {"-s": ("2",)}, "2.png"),  # a numeric-looking name stays the name
    ],
)
def test_map_statement_options(rest: str, options: dict, name: str) -> None:
    """Options before the file name are taken with their words (-o/-s/-t up to three
    numbers), and the rest of the line, spaces kept, is the name."""
    assert parse_map_statement(rest) == (options, name)
