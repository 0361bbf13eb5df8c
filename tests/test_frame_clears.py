"""The frame's clears, each through the framebuffer its pass then draws into (llvmpipe
clears in that draw's scene): GBuffer.clear (app/render/gbuffer.py) clears RT2 (no
surface: depth 0) and the z-buffer only, the other targets masked, and the pass's draws
then write every target again; PostPass.display_target clears the display image alone."""

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


def test_the_display_target_clear_keeps_the_hdr_attachment_and_the_z_buffer(gl_egl: GLContext):
    """PostPass.display_target clears the display image to the background's bytes through
    the framebuffer the fused lighting pass draws into, whose second attachment (the HDR
    image gbaa mixes) and z-buffer must keep what they hold."""
    ctx = gl_egl.ctx
    r = Renderer(gl_egl, parse_scene(many_lights_scene(4, 5.0, SIZE), "clear.toml"), SIZE)
    try:
        r.gbuffer_pass.run(r.gbuffer, r.view, r.proj, r.camera)
        if r.culler is not None:
            r.culler.run(r.gbuffer, r.view, r.camera)
        hdr = r.lighting.hdr
        fbo = ctx.framebuffer([hdr])
        fbo.clear(MARK, MARK, MARK, MARK)
        fbo.release()
        target = r.post.display_target(r.gbuffer.zbuffer, (0.25, 0.5, 0.125), 0.0, hdr)
        value = r.post.background_display((0.25, 0.5, 0.125), 0.0)
        display = np.frombuffer(r.post.target.read(), np.uint8).reshape(SIZE[1], SIZE[0], 4)
        kept = np.frombuffer(hdr.read(), np.float32).reshape(SIZE[1], SIZE[0], 4)
        # the z-buffer still holds the surfaces: the fused lighting draw, z-tested ">" on
        # the far plane, writes them
        r.lighting.run_display(r.gbuffer, r.camera, target, "aces", 1.0, True)
        shaded = np.frombuffer(r.post.target.read(), np.uint8).reshape(SIZE[1], SIZE[0], 4)
        surface = r.read_gbuffer().depth > 0.0
    finally:
        r.release()
    assert np.all(display == np.array(value, np.uint8))
    assert np.all(kept == MARK)
    assert surface.any() and np.all(np.any(shaded != display, axis=-1) == surface[::-1])
