"""``render.normal_filter = "auto"`` (the default): LEAN's covariance for a normal map whose
slopes spread along one direction (grooves, brushing), the isotropic variance chain for any
other, chosen from a sample of the map's footprints (app/textures/lean.py ``auto_filter``,
its float64 twin app/reference/filtering.py ``mean_footprint_covariance``;
docs/filtering.md, "Choosing LEAN: auto")."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.common.models import MaterialParams
from app.reference.filtering import (
    DIRECTIONAL_ANISOTROPY,
    SPREAD_FOOTPRINTS,
    directional_spread,
    mean_footprint_covariance,
    spread_anisotropy,
)
from app.scene import gltf
from app.scene.layers import LayerBuilder
from app.scene.loader import parse_scene
from app.scene.model import RenderSettings
from app.textures.lean import auto_filter, sampled_spread, spread_levels
from app.textures.maps import decode_normals
from tests.conftest import REPO
from tests.gltf_builder import GltfBuilder

TEXTURES = REPO / "scenes" / "textures"
GROOVES = TEXTURES / "groove_normal.png"
STANDIN_GROOVES = REPO / "tests" / "assets" / "anisotropy_rotation" / "grooves_normal.png"


def groove_map(size: int, angle_deg: float, slope_deg: float, period: float = 6.0) -> np.ndarray:
    """An 8-bit normal map of straight scallop grooves whose normals tilt within
    +-``slope_deg`` across grooves running at ``angle_deg`` from the map's x axis."""
    y, x = np.mgrid[0:size, 0:size] + 0.5
    a = math.radians(angle_deg)
    across = -x * math.sin(a) + y * math.cos(a)  # the coordinate across the grooves
    phase = (across / period) % 1.0 * 2.0 - 1.0  # -1..1 over a groove
    tilt = np.radians(slope_deg) * phase
    n = np.stack([-np.sin(tilt) * -math.sin(a), -np.sin(tilt) * math.cos(a), np.cos(tilt)], axis=-1)
    return np.round((n * 0.5 + 0.5) * 255.0).astype(np.uint8)


def noise_map(size: int, slope: float, seed: int = 7) -> np.ndarray:
    """An 8-bit normal map of independent random slopes (an isotropic spread)."""
    s = np.random.default_rng(seed).normal(0.0, slope, (size, size, 2))
    n = np.dstack([-s, np.ones((size, size))])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.round((n * 0.5 + 0.5) * 255.0).astype(np.uint8)


def rgb(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


def test_auto_picks_lean_for_groove_maps_and_variance_for_isotropic_ones() -> None:
    """The groove maps (the grooves scene's, the AnisotropyRotationTest stand-in's, and
    synthetic grooves at any angle) spread along one direction: anisotropy 0.97-1.0 of the
    mean footprint covariance, so ``lean``; the bundled bumpy, flake and orange-peel maps
    and white noise spread every way (anisotropy <= 0.04), and grooves too shallow to
    matter (1 degree) carry too little spread: ``variance``."""
    for path in (GROOVES, STANDIN_GROOVES):
        assert auto_filter(rgb(path)) == "lean", path
    for angle in (0.0, 30.0, 90.0, 135.0):
        assert auto_filter(groove_map(128, angle, 25.0)) == "lean", angle
    for name in ("bumpy_normal.png", "flake_normal.png", "orange_peel_normal.png"):
        assert auto_filter(rgb(TEXTURES / name)) == "variance", name
    assert auto_filter(noise_map(128, 0.3)) == "variance"
    shallow = groove_map(128, 0.0, 1.0)
    anisotropy, trace = spread_anisotropy(sampled_spread(shallow))
    assert anisotropy >= DIRECTIONAL_ANISOTROPY and auto_filter(shallow) == "variance", trace
    # a normal map's scale flattens the grooves alike (glTF normalTexture.scale)
    assert auto_filter(rgb(GROOVES), 0.05) == "variance"


def test_auto_asks_two_levels_for_one_direction() -> None:
    """Bumps 16 texels apart, slopes 0.5 cos(2 pi x/16) and 0.5 sin(2 pi y/16): 8 x 8-texel
    footprints locked to their phase hold a cosine's half period across x (-1..1) and a
    sine's along y (0..1), anisotropy 0.64; the 16 x 16 ones hold whole periods of both,
    round: ``variance``. The grooves stay directional at both levels."""
    y, x = np.mgrid[0:256, 0:256] / 256.0 * 2.0 * np.pi
    slope = 0.5 * np.stack([np.cos(16 * x), np.sin(16 * y)], -1)
    n = np.concatenate([-slope, np.ones((256, 256, 1))], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    bumps = np.round((n * 0.5 + 0.5) * 255.0).astype(np.uint8)
    levels = spread_levels(bumps)
    assert len(levels) == 2 and spread_anisotropy(levels[0])[0] >= DIRECTIONAL_ANISOTROPY
    assert spread_anisotropy(levels[1])[0] <= 0.1 and auto_filter(bumps) == "variance"
    assert len(spread_levels(rgb(GROOVES))) == 2 and auto_filter(rgb(GROOVES)) == "lean"
    assert len(spread_levels(rgb(TEXTURES / "bumpy_normal.png"))) == 1  # one level decides


@pytest.mark.parametrize(
    ("texels", "scale"),
    [
        (rgb(GROOVES), 1.0),
        (rgb(STANDIN_GROOVES), 1.0),  # 1024 x 16: one footprint row
        (rgb(TEXTURES / "bumpy_normal.png"), 0.5),
        (groove_map(1100, 20.0, 25.0)[:1100, :900], 1.0),  # more footprints than sampled
        (noise_map(6, 0.3), 2.0),  # smaller than a footprint
    ],
)
def test_sampled_spread_is_its_float64_twin(texels: np.ndarray, scale: float) -> None:
    """The choice's statistic from the sampled 8-bit texels alone (and from decoded
    normals, a scene file's path) is the float64 twin's mean footprint covariance of the
    decoded map, to rounding."""
    normals = decode_normals(Image.fromarray(texels, "RGB"), scale)
    wants = [mean_footprint_covariance(normals, f) for f in SPREAD_FOOTPRINTS]
    for footprint, want in zip(SPREAD_FOOTPRINTS, wants, strict=True):
        for got in (
            sampled_spread(texels, scale, footprint),
            sampled_spread(normals, 1.0, footprint),
        ):
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    assert directional_spread(np.array(wants)) == (auto_filter(texels, scale) == "lean")


def test_auto_is_the_default() -> None:
    assert RenderSettings().normal_filter == "auto"


def test_auto_builds_lean_maps_for_a_grooved_gltf_material_only(tmp_path) -> None:
    """A glTF file with a grooved and a bumpy material: under ``auto`` the grooved one gets
    LEAN's covariance map and shades anisotropically, the bumpy one the variance chain,
    the same prepared entry as an explicit ``variance`` (its chain is not built again)."""
    b = GltfBuilder()
    for image in (Image.open(GROOVES), Image.open(TEXTURES / "bumpy_normal.png")):
        b.quad(
            b.material(
                pygltflib.Material(
                    pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(roughnessFactor=0.2),
                    normalTexture=pygltflib.NormalMaterialTexture(index=b.texture(image)),
                )
            )
        )
    path = b.save(tmp_path / "two.glb")
    fallback = MaterialParams((1.0, 1.0, 1.0), 1.0, 0.5, 0.9)
    file = gltf.GltfFile(path)
    grooved, bumpy = (file.layer(i, fallback, "auto") for i in (0, 1))
    assert "slope_covariance" in grooved.maps and grooved.params.model.anisotropic
    assert "slope_covariance" not in bumpy.maps and not bumpy.params.model.anisotropic
    explicit = {f: file.layer(i, fallback, f) for i, f in ((0, "lean"), (1, "variance"))}
    assert grooved.maps["normal_roughness"].levels.parts == (
        explicit["lean"].maps["normal_roughness"].levels.parts
    )
    assert bumpy.maps["normal_roughness"].levels.parts == (
        explicit["variance"].maps["normal_roughness"].levels.parts
    )


def test_auto_builds_lean_maps_for_a_scene_files_groove_map() -> None:
    """scenes/sec13_grooves.toml's grooved materials under ``auto`` (the default, its own
    ``lean`` left out) get the covariance map, as with ``lean``; sec13_filtering's bumpy
    floor keeps the variance chain."""
    for name, want in (("sec13_grooves", True), ("sec13_filtering", False)):
        path = REPO / "scenes" / f"{name}.toml"
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        data["render"].pop("normal_filter", None)
        loaded = parse_scene(data, path)
        builder = LayerBuilder(loaded)
        mapped = [m for m, mat in loaded.scene.materials.items() if mat.normal_map is not None]
        assert mapped, name
        for material in mapped:
            layer = builder.layer(material)
            assert ("slope_covariance" in layer.maps) == want, (name, material)
