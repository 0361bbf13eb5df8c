"""The lighting pass's background (app/render/lighting.py, LightingPass.run): the HDR
target is not cleared before the draw, so every pixel must still be written, those
without a surface by passes/hdr_background.frag (the z-buffer's cleared far value) and
those with a z but a depth the decode counts as none by the lighting program itself."""

from __future__ import annotations

import numpy as np
import pytest

from app.bench.scenes import many_lights_scene
from app.common.gbuffer import DEFAULT_ENCODING
from app.gl.context import GLContext
from app.render.debug import write_bit_patterns
from app.render.fullscreen import read_rgba
from app.render.renderer import Renderer
from app.scene.loader import parse_scene

pytestmark = pytest.mark.gl

SIZE = (64, 36)
NAN_BITS = 0x7FC00000
# A GL rectangle (x, y from the bottom, w, h) of the floor, which covers the image's
# lower part: every pixel in it has a surface.
FLOOR_RECT = (24, 2, 8, 4)


def _frame(gl: GLContext) -> Renderer:
    data = many_lights_scene(16, 5.0, SIZE, gbuffer=DEFAULT_ENCODING)
    r = Renderer(gl, parse_scene(data, "background.toml"), SIZE)
    r.gbuffer_pass.run(r.gbuffer, r.view, r.proj, r.camera)
    if r.culler is not None:
        r.culler.run(r.gbuffer, r.view, r.camera)
    return r


def _run(r: Renderer, background: np.ndarray) -> np.ndarray:
    """The HDR target after LightingPass.run over a target holding another value."""
    r.lighting.fbo.clear(7.0, -7.0, 7.0, 7.0)
    r.lighting.run(r.gbuffer, r.camera, background)
    return read_rgba(r.lighting.fbo, SIZE, "f4")


@pytest.mark.parametrize("transparent", [False, True])
def test_background_pixels_are_written_without_a_clear(gl_egl: GLContext, transparent: bool):
    """Each pixel without a surface holds the background (RGB and alpha 1, or the RGBA 0 a
    transparent background passes) to the bit, whatever the target held, and the surfaces'
    pixels are the same as over a cleared target."""
    r = _frame(gl_egl)
    try:
        background = np.array([0.25, 0.5, 0.125])
        if transparent:
            background = np.zeros(4)
        hdr = _run(r, background)
        r.lighting.fbo.clear(*(float(x) for x in background), *([] if transparent else [1.0]))
        r.lighting._shade(r.lighting.draws, r.lighting._z_target(r.gbuffer), r.camera)
        cleared = read_rgba(r.lighting.fbo, SIZE, "f4")
        depth = r.read_gbuffer().depth
    finally:
        r.release()
    empty = ~(np.isfinite(depth) & (depth > 0.0))
    assert 0 < empty.sum() < empty.size  # the frame has both kinds of pixel
    want = np.append(background, 1.0) if len(background) == 3 else background
    assert np.array_equal(hdr[empty], np.broadcast_to(want.astype(np.float32), hdr[empty].shape))
    assert np.array_equal(hdr.view(np.uint32), cleared.view(np.uint32))


def test_a_surface_whose_depth_decodes_as_none_shows_the_background(gl_egl: GLContext):
    """A pixel the z-buffer gives a surface but whose G-buffer depth is NaN (decode_gbuffer
    counts it as none) holds the background, as it did when the pass cleared the target:
    the lighting program writes it there rather than discarding."""
    r = _frame(gl_egl)
    try:
        before = r.read_gbuffer().depth
        depth_fbo = gl_egl.ctx.framebuffer([r.gbuffer.depth])
        try:
            write_bit_patterns(gl_egl.ctx, depth_fbo, [(NAN_BITS, 0, FLOOR_RECT)])
        finally:
            depth_fbo.release()
        background = np.array([0.25, 0.5, 0.125])
        hdr = _run(r, background)
    finally:
        r.release()
    x, y, w, h = FLOOR_RECT
    rows = slice(SIZE[1] - y - h, SIZE[1] - y)
    assert np.all(np.isfinite(before[rows, x : x + w]))  # a surface was there
    want = np.array([0.25, 0.5, 0.125, 1.0], np.float32)
    assert np.array_equal(hdr[rows, x : x + w], np.broadcast_to(want, (h, w, 4)))
