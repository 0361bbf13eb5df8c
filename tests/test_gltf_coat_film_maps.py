"""glTF clearcoatRoughnessTexture, iridescenceTexture and iridescenceThicknessTexture
rendered (real GL, real shaders): per-pixel factors through the optional G-buffer target
RT8 (``coat_film_maps``, app/common/gbuffer.py), each image against the float64 twin's
shading of its own G-buffer, on the quad of tests/test_gltf_extension_maps.py split into
halves by a texture (column j mirrors column N - 1 - j). The G-buffer of a scene without
these maps has no RT8 (its bytes per pixel unchanged)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.common.gbuffer import GBufferLayout
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.gltf_builder import GltfBuilder
from tests.test_gltf_extension_maps import (
    NEAREST,
    NO_BASE,
    ON_AXIS,
    QUAD_N,
    QUAD_SCENE,
    dielectric,
    halves,
    render_quad,
)

pytestmark = pytest.mark.gl
HALF = QUAD_N // 2


def _mirrored_halves(hdr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the left half column-mirrored onto the right, the right half)."""
    return hdr[:, :HALF][:, ::-1], hdr[:, HALF:]


def test_clearcoat_roughness_texture_blurs_the_coat_highlight_where_it_is_one(gl_egl, tmp_path):
    """clearcoatRoughnessTexture (G) multiplies clearcoatRoughnessFactor 1 per pixel: 1 on
    the quad's left half (a rough coat), 0.1 on its right, over a black base without a
    specular lobe (the image is the coat alone). The right half's highlight peaks higher
    than its mirror on the left, which spreads it far wider; every pixel is the twin's.
    Fails with the texture ignored (both halves equally rough)."""
    b = GltfBuilder()
    tex = b.texture(halves((0, 255, 0), (0, 26, 0)), NEAREST)
    coat = {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 1.0,
            "clearcoatRoughnessTexture": {"index": tex}}  # fmt: skip
    b.quad(b.material(dielectric({**NO_BASE, "KHR_materials_clearcoat": coat})))
    hdr, ref, g = render_quad(
        gl_egl, tmp_path, b, ["KHR_materials_clearcoat", "KHR_materials_specular"]
    )
    f = g.coat_film_maps
    assert f is not None and g.layer_maps is None
    np.testing.assert_array_equal(f[:, :HALF, 0], 1.0)
    np.testing.assert_allclose(f[:, HALF:, 0], 26 / 255, atol=1e-4)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    rough, smooth = _mirrored_halves(hdr)
    assert smooth.max() > 1.3 * rough.max() > 0.0  # the sharp peak (the light on the axis)
    assert rough[:, -4:].mean() > 5.0 * smooth[:, -4:].mean()  # the blurred tail


def _film(extra: dict) -> dict:
    """A 400 nm film of index 1.3 on a black dielectric (ior 1.5), its Fresnel the image."""
    return {"iridescenceFactor": 1.0, "iridescenceIor": 1.3,
            "iridescenceThicknessMaximum": 400.0, **extra}  # fmt: skip


def _hue_spread(rgb: np.ndarray) -> np.ndarray:
    """(max - min) / max of each lit pixel's channels: 0 for grey, large for a colour."""
    return (rgb.max(axis=-1) - rgb.min(axis=-1)) / np.maximum(rgb.max(axis=-1), 1e-12)


def _grey_left_film_right(gl: GLContext, tmp_path: Path, b: GltfBuilder, channel: int) -> None:
    """Render ``b``'s iridescent quad: RT8's ``channel`` reads 0 on the left half and 1 on
    the right, every pixel is the twin's, the left half reflects grey Fresnel alone and the
    right half the film's colours."""
    hdr, ref, g = render_quad(gl, tmp_path, b, ["KHR_materials_iridescence"])
    f = g.coat_film_maps
    assert f is not None
    np.testing.assert_array_equal(f[:, :HALF, channel], 0.0)
    np.testing.assert_array_equal(f[:, HALF:, channel], 1.0)
    np.testing.assert_allclose(hdr, ref, rtol=2e-3, atol=1e-6)
    grey, film_half = _mirrored_halves(hdr)
    lit = film_half.max(axis=-1) > 1e-3
    assert lit.sum() > 100
    assert _hue_spread(grey[lit]).max() < 1e-3
    assert _hue_spread(film_half[lit]).mean() > 0.2


def test_iridescence_texture_zero_removes_the_film_colour_there(gl_egl, tmp_path):
    """iridescenceTexture (R) multiplies iridescenceFactor per pixel: 0 on the quad's left
    half, 1 on its right. The left half reflects the base's grey Fresnel alone, the right
    half the film's colours; every pixel is the twin's. Fails with the texture ignored
    (both halves coloured) and where the film's strength is not applied."""
    b = GltfBuilder()
    tex = b.texture(halves((0, 0, 0), (255, 0, 0)), NEAREST)
    film = _film({"iridescenceTexture": {"index": tex}})
    b.quad(b.material(dielectric({"KHR_materials_iridescence": film})))
    _grey_left_film_right(gl_egl, tmp_path, b, 1)


def test_iridescence_thickness_texture_sets_the_film_between_min_and_max(gl_egl, tmp_path):
    """iridescenceThicknessTexture (G) puts the film between iridescenceThicknessMinimum
    (0 nm: no film) where it reads 0, on the quad's left half, and the maximum (400 nm)
    where it reads 1, on its right: grey Fresnel left, the film's colours right; every
    pixel is the twin's. Fails with the texture ignored (400 nm everywhere)."""
    b = GltfBuilder()
    tex = b.texture(halves((0, 0, 0), (0, 255, 0)), NEAREST)
    film = _film({"iridescenceThicknessMinimum": 0.0,
                  "iridescenceThicknessTexture": {"index": tex}})  # fmt: skip
    b.quad(b.material(dielectric({"KHR_materials_iridescence": film})))
    _grey_left_film_right(gl_egl, tmp_path, b, 2)


def test_a_scene_without_these_maps_allocates_no_rt8():
    """The target is optional: the G-buffer's bytes per pixel grow only with it."""
    plain = GBufferLayout()
    with_maps = GBufferLayout(optional=plain.optional | {"coat_film_maps"})
    assert "coat_film_maps" not in {t.name for t, _ in plain.targets()}
    assert with_maps.bytes_per_pixel() - plain.bytes_per_pixel() == 16  # RGBA32F


def test_a_blended_film_samples_its_strength_texture_as_the_deferred_one(gl_egl, tmp_path):
    """The blend pass shades alpha-blended parts forward (no G-buffer): the film quad of
    the strength texture above, alphaMode BLEND at alpha 1, gives the opaque quad's
    image (the forward pass scales the row by RT8's factors too). Fails with the forward
    pass ignoring the texture (its grey half coloured)."""
    images = []
    for mode in ("OPAQUE", "BLEND"):
        b = GltfBuilder()
        tex = b.texture(halves((0, 0, 0), (255, 0, 0)), NEAREST)
        film = _film({"iridescenceTexture": {"index": tex}})
        mat = dielectric({"KHR_materials_iridescence": film})
        mat.alphaMode = mode
        b.quad(b.material(mat))
        b.doc.extensionsUsed = ["KHR_materials_iridescence"]
        b.save(tmp_path / "m.glb")
        (tmp_path / "scene.toml").write_text(QUAD_SCENE, encoding="utf-8")
        r = Renderer(gl_egl, load_scene(tmp_path / "scene.toml"), (QUAD_N, QUAD_N))
        try:
            assert r.frame.parts[0].layers[0].alpha_mode == mode.lower()
            r.set_lights([ON_AXIS])
            r.render()
            images.append(r.read_hdr().astype(np.float64))
        finally:
            r.release()
    opaque, blended = images
    assert _hue_spread(opaque[:, HALF:][opaque[:, HALF:].max(axis=-1) > 1e-3]).mean() > 0.2
    np.testing.assert_allclose(blended, opaque, rtol=1e-3, atol=1e-6)
