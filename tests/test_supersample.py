"""render.supersample: the resolve (glsl/passes/downsample.frag) is the box average of
the linear HDR image rendered n times larger in each direction."""

from __future__ import annotations

import numpy as np

from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene, load_scene
from tests.conftest import REPO


def _render_hdr(gl: GLContext, loaded: LoadedScene, size: tuple[int, int], n: int) -> np.ndarray:
    settings = loaded.scene.render.model_copy(update={"supersample": n})
    scene = loaded.scene.model_copy(update={"render": settings})
    r = Renderer(gl, LoadedScene(scene, loaded.path), size)
    try:
        r.render()
        return r.read_hdr()
    finally:
        r.release()


def test_supersampled_pixel_is_the_mean_of_its_block(gl: GLContext) -> None:
    """3x3 supersampling at 64x36 equals the 192x108 image averaged over 3x3 blocks, to
    float32 rounding of a nine-term sum (1e-6 relative), and differs from the 64x36 image
    rendered with one sample (the edges are antialiased)."""
    loaded = load_scene(REPO / "scenes" / "showcase.toml")
    big = _render_hdr(gl, loaded, (192, 108), 1).astype(np.float64)
    resolved = _render_hdr(gl, loaded, (64, 36), 3).astype(np.float64)
    plain = _render_hdr(gl, loaded, (64, 36), 1).astype(np.float64)
    want = big.reshape(36, 3, 64, 3, 3).mean(axis=(1, 3))
    scale = float(np.abs(want).max())
    assert np.abs(resolved - want).max() <= 1e-6 * scale
    assert np.abs(plain - want).max() > 1e-2 * scale
