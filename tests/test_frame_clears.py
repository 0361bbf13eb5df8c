"""GBuffer.clear (app/render/gbuffer.py): a frame clears RT2 (no surface: depth 0) and the
z-buffer only, through the G-buffer pass's own framebuffer with the other targets masked,
and the pass's draws then write every target again."""

from __future__ import annotations

import numpy as np
import pytest

from app.bench.scenes import many_lights_scene
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import parse_scene

pytestmark = pytest.mark.gl

SIZE = (48, 27)
MARK = 3.0  # what every target holds before the frame


def test_only_rt2_and_z_are_cleared_and_every_target_is_drawn(gl_egl: GLContext):
    r = Renderer(gl_egl, parse_scene(many_lights_scene(4, 5.0, SIZE), "clear.toml"), SIZE)
    try:
        g = r.gbuffer
        for texture in g._targets:
            fbo = gl_egl.ctx.framebuffer([texture])
            fbo.clear(MARK, MARK, MARK, MARK)
            fbo.release()
        r.gbuffer_pass.run(g, r.view, r.proj, r.camera)
        depth = np.frombuffer(g.depth.read(), np.float32).reshape(SIZE[1], SIZE[0], 2)
        normal = np.frombuffer(g.normal.read(), np.float32).reshape(SIZE[1], SIZE[0], -1)
    finally:
        r.release()
    surface = depth[..., 0] > 0.0
    assert 0 < surface.sum() < surface.size
    assert np.all(depth[~surface] == 0.0)  # RT2 cleared where nothing was drawn
    assert np.all(normal[~surface] == MARK)  # the normal target is not cleared
    assert not np.any(np.all(normal[surface] == MARK, axis=-1))  # but drawn at every surface
