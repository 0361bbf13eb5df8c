"""A decoded RGB image's texels are read in Pillow's own storage (app/textures/
pillow_view.py): the same values as ``np.asarray``'s copy, a view that outlives the image,
and a copy where Pillow's allocator split the rows."""

from __future__ import annotations

import gc
import io

import numpy as np
from PIL import Image

from app.textures.maps import rgb_texels
from app.textures.pillow_view import rgbx_view


def _decoded(side: int = 96) -> Image.Image:
    rng = np.random.default_rng(7)
    data = io.BytesIO()
    Image.fromarray(rng.integers(0, 256, (side, side + 8, 3), np.uint8)).save(data, "JPEG")
    image = Image.open(io.BytesIO(data.getvalue()))
    image.load()
    return image


def test_rgb_texels_read_in_place() -> None:
    image = _decoded()
    expected = np.asarray(image).copy()
    texels = rgb_texels(image)
    assert texels.strides[1] == 4  # Pillow's 4-byte texels, not a packed copy
    assert not texels.flags.writeable
    assert np.array_equal(texels, expected)
    del image
    gc.collect()
    np.ones(1 << 20)  # memory handed out again meanwhile
    assert np.array_equal(texels, expected)  # the storage is kept while the view lives


def test_split_rows_are_copied() -> None:
    """Rows in several blocks of Pillow's allocator have no one view: copied instead."""
    size = Image.core.get_block_size()
    Image.core.set_block_size(4096)
    try:
        image = _decoded()
    finally:
        Image.core.set_block_size(size)
    assert rgbx_view(image) is None
    texels = rgb_texels(image)
    assert texels.strides[1] == 3
    assert np.array_equal(texels, np.asarray(image))


def test_colour_rows_copied_from_the_view(tmp_path, monkeypatch) -> None:
    """A colour map's rows (bottom first, 4 bytes a texel) are one copy of Pillow's
    storage, never its raw encoder's pieces joined; the values are convert("RGBA")'s."""
    from app.textures import maps

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))  # made here, not read
    image = _decoded()
    image.info[maps.SOURCE_DIGEST] = "test-colour-rows"
    expected = np.asarray(image.convert("RGBA"))

    def refused(*args, **kwargs):
        raise AssertionError("the texels were encoded")

    monkeypatch.setattr(Image.Image, "tobytes", refused)
    texture = maps.colour_texture(image)
    assert np.array_equal(texture.levels[0], expected)
