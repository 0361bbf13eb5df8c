"""The public base of image-to-image passes: a full-screen program drawn into a target
of its own, and the read-back every pass's image goes through.

``FullscreenPass`` is a ``FullscreenDraw`` (app/gl/fullscreen.py: the program of a
fragment file and defines behind passes/fullscreen.vert, one empty vertex array) with an
RGBA target of one size: post, the supersampling resolve, depth of field and the
comparison's composite are each a subclass that names its fragment file and defines and
calls ``draw`` with its textures and uniforms. Passes that draw into a target they do not
own (lighting, the environment background, tile culling, the debug views, the bench's
floor and limit) hold a ``FullscreenDraw`` per program instead.
"""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from app.gl.context import release_objects, wait_before_read
from app.gl.fullscreen import FullscreenDraw, Textures
from app.gl.shaders import ShaderCache


def read_rgb(
    fbo: moderngl.Framebuffer, size: tuple[int, int], dtype: str, scratch: bytearray | None = None
) -> np.ndarray:
    """``fbo``'s first attachment as (H, W, 3) float32 ("f4") or uint8 ("f1"), rows top to
    bottom. GL packs the three channels (glReadPixels with GL_RGB, rows 1-byte aligned),
    so the only copy in numpy is the row flip, a contiguous copy per row: reading RGBA and
    slicing off alpha, a strided copy, took 4x as long for 1280x720 RGBA8 here
    (docs/performance.md). ``scratch``: a buffer of the packed image's size to read into,
    kept by a caller that reads every frame (fresh memory for each read is paged in
    again; docs/performance.md, "The fused display image"). The same bytes either way."""
    w, h = size
    wait_before_read(fbo.ctx)
    item = np.dtype(np.float32 if dtype == "f4" else np.uint8)
    if scratch is None:
        data: bytes | bytearray = fbo.read(components=3, alignment=1, dtype=dtype)
    else:
        fbo.read_into(scratch, components=3, alignment=1, dtype=dtype)
        data = scratch
    out = np.empty((h, w, 3), item)
    np.copyto(out, np.frombuffer(data, item, h * w * 3).reshape(h, w, 3)[::-1])
    return out


def read_rgba(fbo: moderngl.Framebuffer, size: tuple[int, int], dtype: str) -> np.ndarray:
    """``fbo``'s first attachment with its alpha, (H, W, 4) float32 ("f4") or uint8
    ("f1"), rows top to bottom (a transparent background's image, docs/architecture.md
    "Alpha")."""
    w, h = size
    wait_before_read(fbo.ctx)
    item = np.dtype(np.float32 if dtype == "f4" else np.uint8)
    data = fbo.read(components=4, alignment=1, dtype=dtype)
    return np.ascontiguousarray(np.frombuffer(data, item, h * w * 4).reshape(h, w, 4)[::-1])


class FullscreenPass:
    """A full-screen pass of glsl/``fragment`` (with ``defines``) into its own RGBA target
    of ``size`` (``dtype`` "f4": linear HDR, NEAREST; "f1": the 8-bit display image)."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        fragment: str,
        defines: Mapping[str, object] | None,
        size: tuple[int, int],
        dtype: str = "f4",
    ) -> None:
        self.ctx = ctx
        self.fullscreen = FullscreenDraw.of(ctx, shaders, fragment, defines)
        self.program = self.fullscreen.program
        self.target = ctx.texture(size, 4, dtype=dtype)
        self.target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.target])
        self._scratch: bytearray | None = None  # read: the display image's read buffer
        self.size = size

    def draw(self, uniforms: Mapping[str, object], textures: Textures) -> None:
        """Draw into the whole target with ``textures`` on units 0, 1, ... and ``uniforms``,
        without depth test or blending."""
        self.fullscreen.draw(self.fbo, uniforms, textures, viewport=(0, 0, *self.size))

    def read(self) -> np.ndarray:
        """(H, W, 3) float32 (HDR) or uint8 (display), rows top to bottom; the display
        image through a buffer kept for the next read (``read_rgb``)."""
        if self.target.dtype != "f1":
            return read_rgb(self.fbo, self.size, self.target.dtype)
        if self._scratch is None:
            self._scratch = bytearray(self.size[0] * self.size[1] * 3)
        return read_rgb(self.fbo, self.size, "f1", self._scratch)

    def release(self) -> None:
        release_objects(self.fullscreen, self.fbo, self.target)
