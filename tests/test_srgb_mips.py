"""A colour map's mips drawn by glsl/passes/srgb_mips.frag (app/render/srgb_mips.py) against
their float64 twin (app/reference/footprint.py): each texel the mean of its footprint (in
image rows: an odd last row of the image joins the pair above it) in linear light, to
llvmpipe's 8-bit sRGB rounding, which each level made from the rounded one above adds to;
and, on a map of power-of-two sides, the GL's own glGenerateMipmap."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from app.gl.context import GLContext, gl_function
from app.gl.texture_storage import (
    GL_SRGB8_ALPHA8,
    GL_TEXTURE_2D,
    GL_UNSIGNED_BYTE,
    allocated,
    read_level,
    write_level0,
)
from app.reference.footprint import footprint_means, srgb_footprint_levels
from app.render.srgb_mips import draw_srgb_mips

pytestmark = pytest.mark.gl


def _texture(gl: GLContext, texels: np.ndarray):
    h, w = texels.shape[:2]
    texture = allocated(gl.ctx, (w, h), 4, max(w, h).bit_length(), GL_SRGB8_ALPHA8)
    write_level0(texture, 4, texels, GL_UNSIGNED_BYTE)
    return texture


@pytest.mark.parametrize("shape", [(64, 64), (37, 21), (1, 9), (12, 1), (5, 5)])
def test_drawn_mips_are_footprint_means(gl_egl: GLContext, shape: tuple[int, int]) -> None:
    texels = np.random.default_rng(sum(shape)).integers(0, 256, (*shape, 4), np.uint8)
    texture = _texture(gl_egl, texels)
    try:
        draw_srgb_mips(gl_egl.ctx, texture)
        # the texture's rows are bottom first; the footprints are the image's (top first)
        twin = [level[::-1] for level in srgb_footprint_levels(texels[::-1])]
        for k in range(1, max(shape).bit_length()):
            drawn = read_level(texture, k).astype(np.float64)
            assert drawn.shape == twin[k].shape, k
            difference = np.abs(drawn - twin[k])
            assert difference.max() <= 0.5 + k, (k, difference.max())
            assert difference.mean() <= 0.75, (k, difference.mean())  # a rounding is 0.25
    finally:
        texture.release()


def test_power_of_two_mips_are_the_gls(gl_egl: GLContext) -> None:
    """On a 64 x 64 map the drawn levels are glGenerateMipmap's within one 8-bit step."""
    texels = np.random.default_rng(3).integers(0, 256, (64, 64, 4), np.uint8)
    ours, theirs = _texture(gl_egl, texels), _texture(gl_egl, texels)
    try:
        draw_srgb_mips(gl_egl.ctx, ours)
        uint, enum = ctypes.c_uint, ctypes.c_uint
        gl_function(gl_egl.ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, theirs.glo)
        gl_function(gl_egl.ctx, "glGenerateMipmap", [enum])(GL_TEXTURE_2D)
        for k in range(1, 7):
            a, b = read_level(ours, k).astype(int), read_level(theirs, k).astype(int)
            assert np.abs(a - b).max() <= 1, k
    finally:
        ours.release()
        theirs.release()


def test_footprint_means_twin() -> None:
    """The twin's footprints: a 5 x 3 map's level 1 is 2 x 1 texels, the first the mean of
    columns 0-1, the second of columns 2-4 (the odd remainder joins the last pair), over
    all three rows; its level 2 is the whole map's mean."""
    values = np.arange(15, dtype=np.float64).reshape(3, 5, 1)
    level1, level2 = footprint_means(values)[1:]
    assert level1.shape == (1, 2, 1)
    np.testing.assert_allclose(level1[0, :, 0], [values[:, :2].mean(), values[:, 2:].mean()])
    np.testing.assert_allclose(level2[0, 0, 0], values.mean())


@pytest.mark.parametrize("cache", ["on", "off"])
def test_refused_mips_are_the_gls_own(
    gl_egl: GLContext, tmp_path, monkeypatch: pytest.MonkeyPatch, cache: str
) -> None:
    """Where the GL refuses to draw a colour map's mips (an incomplete level framebuffer,
    an error), the upload has the GL generate them (glGenerateMipmap's texels, bit for
    bit) and keeps nothing in the prepared-texture cache."""
    from app.gl.texture_storage import LevelFramebufferError
    from app.render import texture_upload
    from app.textures.maps import Texture

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("PBS_CACHE", cache)
    texels = np.random.default_rng(5).integers(0, 256, (37, 21, 4), np.uint8)

    def refused(*args, **kwargs):
        raise LevelFramebufferError("refused for the test")

    monkeypatch.setattr(texture_upload, "draw_srgb_mips", refused)
    made = texture_upload.upload_texture(
        gl_egl.ctx, Texture([texels], srgb=True, source_key="refused-mips-test")
    )
    theirs = _texture(gl_egl, np.ascontiguousarray(texels[::-1]))
    try:
        uint, enum = ctypes.c_uint, ctypes.c_uint
        gl_function(gl_egl.ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, theirs.glo)
        gl_function(gl_egl.ctx, "glGenerateMipmap", [enum])(GL_TEXTURE_2D)
        for k in range(0, 6):
            assert np.array_equal(read_level(made, k), read_level(theirs, k)), k
        assert not list(tmp_path.rglob("*.npy"))
    finally:
        made.release()
        theirs.release()
