"""The debug views of ``pbs render --debug VIEW`` (app/render/debug_views.py) show what they
say they show, on real GL (EGL, llvmpipe), no mocks.

* G-buffer views: the raw values are the read-back G-buffer's texels, bit for bit (the
  normal: the decoded normal, to float32 rounding of the octahedral decode).
* BRDF views: F, D, G2, f_spec, f_diffuse and one light's term agree with their float64
  twins (app.reference.material.brdf_factors, app.reference.illumination.illumination_sum)
  evaluated on the read-back G-buffer with each pixel's own model, on a scene of five
  model groups (sec8_ndf) and one of anisotropic GGX and Beckmann (sec8_anisotropy), and
  the lights of sec4_lights (point and spot). Budget: MAX_REL_ERR = 1e-4, the whole-image
  budget of tests/test_reference_agreement.py, on interior pixels (no silhouette) away
  from the terminator (|n.l| > 1e-3: a pixel on it may be lit in float32 and not in
  float64, and F, D, G2 jump from 0 there), relative to max(|ref|, 1e-3 x the view's
  peak). Measured on llvmpipe (LLVM 15) at 160x90 (run with -s to print them): at most
  5.8e-5 (G2 near a point light's grazing directions), 1.2e-5 for the light term, 9e-6
  for D and f_spec, 1.4e-6 for F; docs/debug-views.md has the table.
* The ``light`` views of all lights add up to the lighting pass's HDR within float32
  rounding; ``tiles`` is the popcount of the culler's masks per tile.
* The CLI writes the display image; bad views and light indices exit 2 with one line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from app.common.models import unpack_model_params
from app.reference.illumination import decode_gbuffer, illumination_sum
from app.reference.material import brdf_factors, material_F0, surface_reflection
from app.reference.punctual import light_at
from app.render.culling import TILE_SIZE
from app.render.debug_views import (
    DEBUG_VIEWS,
    GBUFFER_VIEWS,
    LIGHT_VIEWS,
    DebugPass,
    display_image,
)
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.agreement import without_shadows
from tests.conftest import REPO
from tests.test_reference_agreement import interior

SIZE = (160, 90)
MAX_REL_ERR = 1e-4


class Frame:
    """A rendered scene with its debug pass and the float64 twin's decode of its G-buffer."""

    def __init__(self, gl, scene: str | Path, size: tuple[int, int] = SIZE) -> None:
        # Unshadowed: the debug views' light terms have no shadow (docs/shadows.md)
        self.renderer = Renderer(gl, without_shadows(load_scene(REPO / "scenes" / scene)), size)
        self.renderer.render()
        self.debug = DebugPass(self.renderer)
        self.gbuffer = self.renderer.read_gbuffer()
        self.decoded = decode_gbuffer(self.gbuffer, self.renderer.camera)

    def values(self, view: str, light: int = 0) -> np.ndarray:
        self.debug.run(view, light)
        return self.debug.read_values()

    def reference(self, view: str, light: int) -> tuple[np.ndarray, np.ndarray]:
        """The twin's (H, W, 3) image of ``view`` for ``light`` and the (H, W) mask of the
        pixels that are well away from that light's terminator."""
        r, g = self.renderer, self.decoded
        table = r.materials.packed()
        lamp = r.lights[light]
        shaded = np.zeros((len(g.material_id), 3))
        away = np.zeros(len(g.material_id), bool)
        for row in np.unique(g.material_id):
            sel = g.material_id == row
            model = r.materials.models[int(table[row, 3, 0])]
            params = unpack_model_params(table[row])
            point = g.point(sel, params)  # nc: the coat's normal, with RT4
            _, l = light_at(lamp, point.position)
            NoL = np.sum(point.n * l, axis=-1)
            away[sel] = np.abs(NoL) > 1e-3
            if view == "light":
                value = illumination_sum(point, model, [lamp], r.scene.render.terms)
            else:
                b = brdf_factors(point, model, l)
                value = {
                    "fresnel": b.F,
                    "ndf": np.repeat(b.D[:, None], 3, axis=-1),
                    "g2": np.repeat(b.G2[:, None], 3, axis=-1),
                    "specular": surface_reflection(b),
                    "diffuse": b.f_diffuse,
                }[view]
                value = np.where(b.lit[:, None], value, 0.0)
            shaded[sel] = value
        image = np.zeros((*g.covered.shape, 3))
        image[g.covered] = shaded
        mask = np.zeros(g.covered.shape, bool)
        mask[g.covered] = away
        return image, mask

    def release(self) -> None:
        self.debug.release()
        self.renderer.release()


@pytest.fixture(scope="module")
def frames(gl_egl):
    cache: dict[str, Frame] = {}

    def get(scene: str) -> Frame:
        if scene not in cache:
            cache[scene] = Frame(gl_egl, scene)
        return cache[scene]

    yield get
    for frame in cache.values():
        frame.release()


# --- G-buffer views ---------------------------------------------------------------------

# view -> the read-back G-buffer's channel it shows (a function of GBufferData).
CHANNELS = {
    "base_color": lambda g: g.base_color[..., :3],
    "roughness": lambda g: g.normal[..., 2:3],
    "metallic": lambda g: g.base_color[..., 3:4],
    "depth": lambda g: g.depth[..., None],
    "material_id": lambda g: g.material_id[..., None],
}
assert set(CHANNELS) | {"normal", "coat_normal"} == set(GBUFFER_VIEWS)


@pytest.mark.parametrize("scene", ["sec8_anisotropy.toml", "sec4_lights.toml"])
@pytest.mark.parametrize("view", list(CHANNELS))
def test_gbuffer_channel_views_are_the_gbuffer_exactly(frames, scene, view):
    frame = frames(scene)
    values = frame.values(view)
    covered = frame.gbuffer.covered
    expected = np.broadcast_to(CHANNELS[view](frame.gbuffer), (*covered.shape, 3))
    assert np.array_equal(values[covered][:, :3], expected[covered])
    assert np.array_equal(values[..., 3], covered.astype(np.float32))
    assert not values[~covered].any(), "the background is (0, 0, 0, 0)"


@pytest.mark.parametrize("scene", ["sec8_anisotropy.toml", "sec4_lights.toml"])
def test_normal_view_is_the_decoded_normal(frames, scene):
    """The world normal the lighting pass shades: the twin's oct_decode of the stored
    texel, to float32 rounding (measured: at most 1.2e-7 per component)."""
    frame = frames(scene)
    values = frame.values("normal")
    g = frame.decoded
    err = np.abs(values[g.covered][:, :3] - g.n).max()
    print(f"{scene}: normal view vs twin decode: max abs error {err:.2e}")
    assert err <= 1e-6


@pytest.mark.parametrize("scene", ["sec12_coat_normal.toml", "sec4_lights.toml"])
def test_coat_normal_view_is_the_decoded_coat_normal(frames, scene):
    """The clear coat's normal the lighting pass shades (RTR4 §9.12): the twin's decode of
    RT4 where the frame has it, the normal itself where it has not."""
    frame = frames(scene)
    values = frame.values("coat_normal")
    g = frame.decoded
    assert (g.nc is not None) == (scene == "sec12_coat_normal.toml")
    err = np.abs(values[g.covered][:, :3] - (g.n if g.nc is None else g.nc)).max()
    assert err <= 1e-6


def _f0_view_and_twin(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """The f0 view's covered pixels (C, 3) and the twin's material_F0 of the same decoded
    G-buffer (each pixel's row scaled by RT6, as the lighting pass reads it)."""
    values = frame.values("f0")[frame.gbuffer.covered][:, :3].astype(np.float64)
    g, table = frame.decoded, frame.renderer.materials.packed()
    want = np.zeros((len(g.material_id), 3))
    for row in np.unique(g.material_id):
        sel = g.material_id == row
        point = g.point(sel, unpack_model_params(table[row]))
        want[sel] = material_F0(point.s, point.params)
    return values, want


def test_f0_view_is_the_metals_base_colour_and_the_dielectrics_f0(frames):
    """sec5_metals: the f0 view is material_F0 (a metal's F0 is its base colour, RGB; a
    dielectric's its G-buffer F0), to float32 rounding."""
    values, want = _f0_view_and_twin(frames("sec5_metals.toml"))
    assert np.abs(values - want).max() <= 1e-6
    assert np.ptp(want, axis=-1).max() > 0.2, "the metals' F0 is coloured"


def test_f0_view_takes_the_specular_colour_and_its_texture(gl_egl, tmp_path):
    """A glTF quad with KHR_materials_specular: specularColorFactor (1, 0.8, 0.6) times a
    specularColorTexture yellow (255, 255, 0) on its left half and white on its right.
    The f0 view is the RGB F0 the lighting's Fresnel takes (the dielectric F0 0.04 times
    the factor times the texel: yellow-tinted on the left, orange-tinted on the right),
    as the twin's material_F0. Fails where the view shows the scalar F0 channel (grey)."""
    from tests.gltf_builder import GltfBuilder
    from tests.test_gltf_extension_maps import NEAREST, QUAD_N, QUAD_SCENE, dielectric, halves

    b = GltfBuilder()
    tex = b.texture(halves((255, 255, 0), (255, 255, 255)), NEAREST)
    ext = {"specularColorFactor": [1.0, 0.8, 0.6], "specularColorTexture": {"index": tex}}
    b.quad(b.material(dielectric({"KHR_materials_specular": ext})))
    b.doc.extensionsUsed = ["KHR_materials_specular"]
    b.save(tmp_path / "m.glb")
    (tmp_path / "scene.toml").write_text(QUAD_SCENE, encoding="utf-8")
    frame = Frame(gl_egl, tmp_path / "scene.toml", (QUAD_N, QUAD_N))  # an absolute path
    try:
        values, want = _f0_view_and_twin(frame)
        image = frame.debug.read_values()[..., :3]
    finally:
        frame.release()
    assert frame.gbuffer.covered.all()
    assert np.abs(values - want).max() <= 1e-6
    left, right = image[:, : QUAD_N // 2], image[:, QUAD_N // 2 :]
    np.testing.assert_allclose(left, np.broadcast_to([0.04, 0.032, 0.0], left.shape), atol=1e-6)
    np.testing.assert_allclose(right, np.broadcast_to([0.04, 0.032, 0.024], right.shape), atol=1e-6)


# --- BRDF views -----------------------------------------------------------------------------

BRDF_CASES = [
    ("sec8_ndf.toml", 0),  # four model groups: GGX, Beckmann, Blinn-Phong, GTR
    ("sec8_anisotropy.toml", 0),  # anisotropic GGX and Beckmann, isotropic ones
    ("sec8_anisotropy.toml", 1),
    ("sec4_lights.toml", 3),  # a point light
    ("sec4_lights.toml", 7),  # a spot light
    ("sec12_coat_normal.toml", 0),  # clear coats with normals of their own (RT4)
]


@pytest.mark.parametrize(("scene", "light"), BRDF_CASES)
@pytest.mark.parametrize("view", LIGHT_VIEWS)
def test_brdf_views_match_the_float64_twin(frames, scene, light, view):
    frame = frames(scene)
    values = frame.values(view, light).astype(np.float64)[..., :3]
    ref, away = frame.reference(view, light)
    sel = interior(frame.gbuffer.covered) & away
    assert np.all(np.isfinite(values))
    peak = np.abs(ref[sel]).max()
    if peak == 0.0:  # e.g. no diffuse lobe: the GPU must give exactly 0 too
        assert not values[sel].any()
        return
    rel = np.abs(values - ref)[sel] / np.maximum(np.abs(ref[sel]), 1e-3 * peak)
    print(f"{scene} light {light} {view}: max relative error {rel.max():.2e}")
    assert rel.max() <= MAX_REL_ERR, f"max relative error {rel.max():.2e}"


@pytest.mark.parametrize("scene", ["sec4_lights.toml", "sec8_anisotropy.toml", "sec8_ndf.toml"])
def test_light_views_add_up_to_the_lighting_pass(frames, scene):
    """sum_i (pi f_i c_i (n.l_i)+) = pi sum_i f_i c_i (n.l_i)+ to float32 rounding: pi
    multiplies each term instead of the sum, so each term may round once more."""
    frame = frames(scene)
    total = sum(
        frame.values("light", i).astype(np.float64)[..., :3]
        for i in range(len(frame.renderer.lights))
    )
    hdr = frame.renderer.read_hdr().astype(np.float64)
    covered = frame.gbuffer.covered
    n = len(frame.renderer.lights)
    bound = 4 * n * np.finfo(np.float32).eps * np.maximum(np.abs(hdr), 1e-30)
    err = np.abs(total - hdr)[covered] / np.maximum(np.abs(hdr[covered]), 1e-30)
    print(f"{scene}: sum of light views vs HDR: max relative difference {err.max():.2e}")
    assert np.all(np.abs(total - hdr)[covered] <= bound[covered])


# --- tiles ---------------------------------------------------------------------------------


def test_tiles_view_is_the_popcount_of_the_culler_masks(frames):
    frame = frames("sec4_lights.toml")
    # 7 local lights: "auto" would not cull them (app/render/culling.py tiles_used)
    r = frame.renderer
    r.set_settings(r.scene.render.model_copy(update={"light_culling": "tiled"}))
    r.render()
    culler = r.culler
    assert culler is not None
    counts = culler.read_masks().sum(axis=-1)  # (tiles_y, tiles_x), tile rows bottom-up
    values = frame.values("tiles")[::-1]  # pixel rows bottom-up, as the tiles
    h, w = values.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    expected = counts[ys // TILE_SIZE, xs // TILE_SIZE]
    assert counts.max() >= 2, "the scene should have tiles with several lights"
    assert np.array_equal(values[..., 0], expected.astype(np.float32))
    assert np.array_equal(values[..., 1], values[..., 0])
    assert np.all(values[..., 3] == 1.0)


def test_tiles_view_under_auto_shows_what_tiled_culls(gl_egl):
    """Below "auto"'s light count the frame is drawn without tiles, yet the tiles view
    shows the masks "tiled" gives the same scene (culled for the view alone)."""
    loaded = without_shadows(load_scene(REPO / "scenes" / "sec4_lights.toml"))
    views = []
    for culling in ("auto", "tiled"):
        r = Renderer(gl_egl, loaded, SIZE)
        r.set_settings(r.scene.render.model_copy(update={"light_culling": culling}))
        debug = DebugPass(r)
        try:
            r.render()
            assert (r.culler is None) == (culling == "auto") and debug.tiled
            debug.run("tiles")
            views.append(debug.read_values())
        finally:
            debug.release()
            r.release()
    assert views[0][..., 0].max() >= 2
    assert np.array_equal(views[0], views[1])


def test_tiles_view_is_zero_without_culling(frames):
    frame = frames("sec8_anisotropy.toml")  # directional lights only: no culler
    assert not frame.debug.tiled
    values = frame.values("tiles")
    assert not values[..., :3].any()
    assert not display_image("tiles", values).any()


# --- the display images -----------------------------------------------------------------------


# Views of per-material constants: one level per material. In sec4_lights Lambert's
# f_diffuse = rho_ss / pi is a constant too, and so, to a display byte, is F for the
# directional light: it stays at F0 until l.h nears grazing (RTR4 §9.5).
FLAT_VIEWS = ("base_color", "material_id", "metallic", "roughness", "f0", "diffuse", "fresnel")


@pytest.mark.parametrize(
    "view", [v for v in DEBUG_VIEWS if v not in ("nan", "tiles", "emission", "occlusion")]
)  # emission and occlusion: black and white without RT5 (tests/test_material_core.py)
def test_display_images_are_neither_black_nor_saturated(frames, view):
    """On sec4_lights with its directional light (a point light's term is exactly 0
    beyond its range, most of the frame), each view's display shows structure: several
    grey levels over the surfaces, not all of them black or white, and the background
    black."""
    frame = frames("sec4_lights.toml")
    frame.debug.run(view, 0)
    image = frame.debug.read_display().astype(np.int64)
    covered = frame.gbuffer.covered
    lum = image[covered].sum(axis=-1)
    if view not in FLAT_VIEWS:
        assert len(np.unique(lum)) >= 16, f"{view}: only {len(np.unique(lum))} levels"
    if view != "metallic":  # 0 or 1 by nature: black or white is the point
        assert np.mean((lum == 0) | (lum == 3 * 255)) < 0.5, f"{view}: mostly black or white"
    assert not image[~covered].any()


# --- the CLI -----------------------------------------------------------------------------


def test_cli_writes_the_display_image(gl_egl, tmp_path):
    out = tmp_path / "ndf.png"
    argv = ["render", "sec8_ndf", "-o", str(out), "--size", "160x90", "--debug", "ndf", "-q"]
    assert main([*argv, "--backend", "egl"]) == 0
    written = np.asarray(Image.open(out).convert("RGB"))
    r = Renderer(gl_egl, load_scene(REPO / "scenes" / "sec8_ndf.toml"), (160, 90))
    try:
        r.render()
        debug = DebugPass(r)
        debug.run("ndf", 0)
        expected = debug.read_display()
        debug.release()
    finally:
        r.release()
    assert np.array_equal(written, expected)


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (["--debug", "fresnell"], "--debug"),
        (["--debug", "ndf", "--debug-light", "9"], "--debug-light"),
        (["--debug", "ndf", "--debug-light", "-1"], "--debug-light"),
        (["--debug", "depth", "--debug-light", "0"], "--debug-light"),
    ],
)
@pytest.mark.gl
def test_cli_bad_debug_input_exits_2_with_one_line(tmp_path, capsys, args, option):
    out = tmp_path / "x.png"
    code = main(["render", "sec4_lights", "-o", str(out), "--size", "32x18", *args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and option in err, err
    assert not out.exists()
