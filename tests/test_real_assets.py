"""Real Khronos sample models rendered with no scene file, in the default look
(app/scene/model_file.py): the reduced DamagedHelmet (tests/assets/DamagedHelmet: a
Draco mesh, five 256^2 JPEG maps, an emissive visor) and BoxTextured.glb (Cesium's
textured box); tests/assets/LICENSE.md gives their licences.

Each image is checked as a person would look at it: the model is framed (it covers a
sane share of the image around its centre), lit (not black, its luminance spread, not
flat), against the light neutral backdrop, and it shows what the asset is (the helmet's
emissive cyan visor ring and orange lights beside worn grey metal, the box's blue and
green Cesium logo on a light grey box). The object's pixels come from the depth read-back,
so the checks take a mask and an RGB(A) image and a transparent-background check can
reuse them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.api import OffscreenRenderer
from app.scene.model_file import BACKDROP
from app.scene.sources import scene_from

pytestmark = pytest.mark.gl

ASSETS = Path(__file__).resolve().parent / "assets"
HELMET = ASSETS / "DamagedHelmet" / "DamagedHelmet.gltf"
BOX = ASSETS / "BoxTextured.glb"
W, H = 192, 108


def _luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def renders() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each asset's (display image as float 0..255, mask of the model's pixels)."""
    out = {}
    for path in (HELMET, BOX):
        with OffscreenRenderer(path, size=(W, H)) as r:
            r.render()
            out[path.name] = (r.ldr().astype(np.float64), r.depth() > 0.0)
    return out


def check_framed(covered: np.ndarray, what: str) -> None:
    """The model covers 15-70 % of the image and its box is centred."""
    share = float(covered.mean())
    assert 0.15 <= share <= 0.70, f"{what}: the model covers {share:.0%} of the image"
    rows, cols = np.nonzero(covered)
    centre = ((cols.min() + cols.max()) / 2 / (W - 1), (rows.min() + rows.max()) / 2 / (H - 1))
    assert max(abs(centre[0] - 0.5), abs(centre[1] - 0.5)) < 0.1, f"{what}: centred at {centre}"


def check_lit(image: np.ndarray, covered: np.ndarray, what: str) -> None:
    """The model's pixels are neither black nor blown out, and not flat: their luminance
    spreads over a range as a key light and an environment give it."""
    lum = _luminance(image[covered])
    assert 25.0 < lum.mean() < 200.0, f"{what}: mean luminance {lum.mean():.1f} of 255"
    spread = np.percentile(lum, 90) - np.percentile(lum, 10)
    assert spread > 40.0, f"{what}: flat lighting (10-90 % spread {spread:.1f})"
    assert np.mean(lum > 250.0) < 0.05, f"{what}: {np.mean(lum > 250.0):.0%} blown out"


def clear_of(covered: np.ndarray) -> np.ndarray:
    """The pixels neither covered nor next to a covered one (antialiasing blends a
    silhouette into its neighbours, so those show a mix of model and backdrop)."""
    near = covered.copy()
    near[1:] |= covered[:-1]
    near[:-1] |= covered[1:]
    near[:, 1:] |= covered[:, :-1]
    near[:, :-1] |= covered[:, 1:]
    return ~near


def check_backdrop(image: np.ndarray, covered: np.ndarray, what: str) -> None:
    """Every pixel clear of the model is the light neutral studio backdrop."""
    grey = 255.0 * BACKDROP
    backdrop = image[clear_of(covered)][:, :3]
    assert np.all(np.abs(backdrop - grey) <= 2.0), f"{what}: backdrop not {grey:.0f} grey"


@pytest.mark.parametrize("name", [HELMET.name, BOX.name])
def test_framed_lit_against_the_backdrop(renders: dict, name: str) -> None:
    image, covered = renders[name]
    check_framed(covered, name)
    check_lit(image, covered, name)
    check_backdrop(image, covered, name)


def test_helmet_shows_its_emissive_visor_on_grey_metal(renders: dict) -> None:
    """The helmet reads as itself: mostly unsaturated worn metal, with the emissive cyan
    ring and orange-yellow lights (bright and saturated pixels of each hue)."""
    image, covered = renders[HELMET.name]
    rgb = image[covered][:, :3]
    saturation = rgb.max(axis=1) - rgb.min(axis=1)
    assert np.mean(saturation < 40.0) > 0.5, "the metal should be mostly grey"
    r, g, b = rgb.T
    cyan = (g > 80.0) & (b > 80.0) & (r < 0.7 * np.minimum(g, b))
    orange = (r > 150.0) & (b < 0.5 * r)
    assert cyan.sum() >= 10, f"no emissive cyan visor ring ({cyan.sum()} pixels)"
    assert orange.sum() >= 3, f"no orange-yellow lights ({orange.sum()} pixels)"


def test_box_shows_the_cesium_logo(renders: dict) -> None:
    """The box reads as the textured Cesium crate: blue and green logo pixels and the
    light grey of the box, on faces lit differently."""
    image, covered = renders[BOX.name]
    rgb = image[covered][:, :3]
    r, g, b = rgb.T
    blue = (b > r + 40.0) & (b > g + 10.0)
    green = (g > r + 20.0) & (g > b + 20.0)
    grey = (rgb.max(axis=1) - rgb.min(axis=1) < 20.0) & (rgb.mean(axis=1) > 120.0)
    for hue, where in (("blue", blue), ("green", green), ("light grey", grey)):
        assert where.mean() > 0.05, f"{hue}: {where.mean():.1%} of the box's pixels"


def test_exposure_is_metered_for_the_asset() -> None:
    """The two assets get different exposures (the dark metal helmet more), each from its
    albedo, and the backdrop shows the same grey under both (checked above)."""
    helmet = scene_from(HELMET, size=(W, H)).scene.camera.exposure
    box = scene_from(BOX, size=(W, H)).scene.camera.exposure
    assert helmet > box + 0.4, (helmet, box)


@pytest.mark.parametrize("name", [HELMET.name, BOX.name])
def test_transparent_background_cuts_the_model_out(renders: dict, name: str) -> None:
    """``--background transparent`` on a real asset (the API's ``background`` setting): no
    backdrop anywhere clear of the model (alpha 0, colour 0); without antialiasing the
    model opaque with the opaque render's colours to the code; with FXAA (set here) its
    silhouette antialiased (fractional alpha). (FXAA's edge walk ends where the luma
    changes, at the backdrop in one image and at nothing in the other, so its pixels near
    the silhouette may differ between the two.)"""
    path = HELMET if name == HELMET.name else BOX
    covered = renders[name][1]
    with OffscreenRenderer(path, size=(W, H)) as r:
        r.set_settings(antialiasing="none")
        opaque = r.render().astype(np.int32)
        r.set_settings(background="transparent")
        plain = r.render().astype(np.int32)
        r.set_settings(antialiasing="fxaa")
        filtered = r.render().astype(np.int32)
    clear = clear_of(covered)
    for rgba in (plain, filtered):
        assert rgba.shape == (H, W, 4)
        assert np.all(rgba[clear] == 0), name
    np.testing.assert_array_equal(plain[..., 3], np.where(covered, 255, 0))
    diff = np.abs(plain[covered][:, :3] - opaque[covered][:, :3])
    assert diff.max() <= 1, f"{name}: the model's colours {diff.max()} codes off the opaque"
    edge = ~clear & ~clear_of(~covered)
    alpha = filtered[..., 3][edge]
    partial = (alpha > 0) & (alpha < 255)
    assert partial.mean() > 0.2, f"{name}: {partial.mean():.0%} of the edge has partial alpha"
