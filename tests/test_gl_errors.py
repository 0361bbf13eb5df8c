"""A render leaves no GL error behind: every framebuffer is released through
``release_objects`` (app/gl/context.py), which unbinds one that moderngl holds as bound
first. moderngl binds the framebuffer it holds as bound again whenever it makes another,
and a released one's name there was a GL_INVALID_OPERATION in every render (the shadow
pass's hardware-PCF probe released its framebuffer while bound, and the next framebuffer
made was the shadow atlas's)."""

from __future__ import annotations

import ctypes

import pytest

from app.gl.context import GLContext, gl_function, release_objects
from app.render.renderer import Renderer
from app.resources import scenes_dir
from app.scene.loader import load_scene

pytestmark = pytest.mark.gl


def _errors(gl: GLContext) -> list[int]:
    error = gl_function(gl.ctx, "glGetError", [], ctypes.c_uint)
    found = []
    for _ in range(16):
        code = error()
        if code == 0:
            break
        found.append(code)
    return found


def test_released_bound_framebuffer_leaves_no_error(gl_egl: GLContext) -> None:
    """The bare case: a framebuffer used, then released, then another made."""
    ctx = gl_egl.ctx
    _errors(gl_egl)
    first = ctx.framebuffer([ctx.texture((4, 4), 4)])
    first.use()
    release_objects(first, *first.color_attachments)
    second = ctx.framebuffer([ctx.texture((4, 4), 4)])
    assert _errors(gl_egl) == []
    release_objects(second, *second.color_attachments)


def test_renders_leave_no_gl_error(gl_egl: GLContext) -> None:
    """Two renderers one after the other (the viewer's and a batch's way: passes released
    and made again), each built, drawn and released: no GL error flag set."""
    _errors(gl_egl)
    for name in ("showcase", "gltf_material_sampler"):
        renderer = Renderer(gl_egl, load_scene(scenes_dir() / f"{name}.toml"), (64, 48))
        renderer.render()
        renderer.read_image()
        renderer.release()
        assert _errors(gl_egl) == [], name
