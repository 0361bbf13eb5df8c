"""Antialiasing (docs/antialiasing.md): the passes behind ``render.antialiasing``.

"fxaa": ``FxaaPass``, a luma-edge filter of the 8-bit display image after the idea of
Lottes' FXAA 3.11 (NVIDIA, 2011): where the local luma contrast is high, find the edge's
direction and its two ends along it, and resample the pixel across the edge by the
fraction of it the edge's ends say it covers (glsl/passes/fxaa.frag, written here).

"jitter": the mean of N frames whose projections are moved by sub-pixel offsets from the
Halton (2, 3) sequence (Halton 1964), each frame's linear HDR image accumulated by
``AccumulatePass``; the mean converges to the box-filtered pixel integral that
``render.supersample`` computes, and is tone-mapped once (tone mapping after averaging,
as the supersampling resolve does). ``jittered_matrices`` moves the camera: the
projection's NDC offset, and the camera frame's ray matrix sheared by the same offset so
that every pass that rebuilds a pixel's ray from its window position (the lighting pass,
analytic primitives, the environment background) follows the jittered raster.
"""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache
from app.render.fullscreen import read_rgb

ANTIALIASING = ("none", "fxaa", "jitter")


def halton(index: int, base: int) -> float:
    """The radical inverse of ``index`` >= 1 in ``base``: the Halton sequence's element."""
    f, r = 1.0, 0.0
    while index > 0:
        f /= base
        r += f * (index % base)
        index //= base
    return r


def jitter_offsets(n: int) -> np.ndarray:
    """(n, 2) sub-pixel offsets in pixels: Halton (2, 3) points 1..n over the pixel's
    square (the box filter's support), moved together so that their mean is the pixel's
    centre (the first four points' mean lies 0.1 pixel off it: the mean image would
    shift by as much)."""
    points = np.array([(halton(k, 2), halton(k, 3)) for k in range(1, n + 1)])
    return points - points.mean(axis=0)


def jittered_frame(
    proj: np.ndarray, frame: CameraFrame, offset: tuple[float, float], size: tuple[int, int]
) -> tuple[np.ndarray, CameraFrame]:
    """The projection and camera frame of a raster moved by ``offset`` pixels of an image
    of ``size``: a point's NDC move by j = 2 offset / size (clip x += j.x w), so the pixel
    at NDC p sees the unjittered ray through p - j, which the frame's ray matrix gives as
    R S with S's third column (j.x tan_x, j.y tan_y, 1) (rays are (ndc tan, -1))."""
    j = (2.0 * offset[0] / size[0], 2.0 * offset[1] / size[1])
    moved = np.array(proj, np.float64)
    # clip = P v, w = -z_view: adding j w to clip x, y is -j in P's z column
    moved[0, 2] -= j[0]
    moved[1, 2] -= j[1]
    shear = np.eye(3)
    shear[0, 2] = j[0] * frame.tan_half_fov[0]
    shear[1, 2] = j[1] * frame.tan_half_fov[1]
    rays = np.asarray(frame.camera_to_world, np.float64) @ shear
    return moved, dataclasses.replace(frame, camera_to_world=rays, jitter=j)


class FxaaPass:
    """The display image (RGBA8, sRGB-encoded) filtered in place: its FXAA-class filtered
    image, alpha filtered with the colour. Luma is taken from the encoded values, as FXAA
    does: edges are found where they are seen. Two draws: the mark copies the image into
    ``source`` (the filter's input: bilinear, clamped) and writes window depth 0 at edge
    pixels, 1 elsewhere; the filter then draws into the display image itself on the far
    plane with the test ">", so that only the blocks of pixels with an edge run the
    search (llvmpipe shades every branch of a fragment shader for its whole block of
    pixels; the z-test skips blocks), and every other pixel keeps its bytes. So whatever
    shows the post pass's target shows the filtered image."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        tuning: dict[str, float] | None = None,
    ):
        tuning = dict(tuning or {})  # FXAA_SUBPIX, FXAA_EDGE_THRESHOLD(_MIN): the bench's
        self.ctx, self.size = ctx, size
        self.mark = FullscreenDraw.of(ctx, shaders, "passes/fxaa.frag", {**tuning, "FXAA_MARK": 1})
        self.filter = FullscreenDraw.of(
            ctx, shaders, "passes/fxaa.frag", {**tuning, "FAR_PLANE": 1}
        )
        self.source = ctx.texture(size, 4, dtype="f1")
        self.source.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.source.repeat_x = self.source.repeat_y = False
        self.depth = ctx.depth_renderbuffer(size)
        self.marked = ctx.framebuffer([self.source], self.depth)
        self._out: moderngl.Framebuffer | None = None  # the display image + ``depth``
        self._out_target: moderngl.Texture | None = None

    def run(self, display: moderngl.Texture) -> None:
        """Filter ``display`` (RGBA8 of ``size``) in place."""
        if self._out is None or self._out_target is not display:
            if self._out is not None:
                self._out.release()
            self._out = self.ctx.framebuffer([display], self.depth)
            self._out.depth_mask = False
            self._out_target = display
        viewport = (0, 0, *self.size)
        self.marked.depth_mask = True
        self.mark.draw(self.marked, {}, {"u_display": display}, viewport=viewport, depth_func="1")
        self.filter.draw(
            self._out, {}, {"u_display": self.source}, viewport=viewport, depth_func=">"
        )

    def release(self) -> None:
        for obj in (self.mark, self.filter, self._out, self.marked, self.depth, self.source):
            if obj is not None:
                obj.release()


class AccumulatePass:
    """The running mean of linear HDR images (RGBA32F, alpha averaged with the colour, so
    premultiplied colour stays premultiplied): ``add(hdr)`` makes the mean of the samples
    so far and ``hdr`` (``restart``: of ``hdr`` alone), ping-ponging two targets;
    ``target`` is the latest mean and ``samples`` how many it holds."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderCache, size: tuple[int, int]):
        self.ctx, self.size = ctx, size
        self.fullscreen = FullscreenDraw.of(ctx, shaders, "passes/accumulate.frag")
        self.targets = [ctx.texture(size, 4, dtype="f4") for _ in range(2)]
        for t in self.targets:
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbos = [ctx.framebuffer([t]) for t in self.targets]
        self.samples = 0
        self._latest = 0

    @property
    def target(self) -> moderngl.Texture:
        return self.targets[self._latest]

    @property
    def fbo(self) -> moderngl.Framebuffer:
        """The framebuffer of ``target`` (read as the other HDR sources are)."""
        return self.fbos[self._latest]

    def add(self, hdr: moderngl.Texture, restart: bool = False) -> None:
        restart = restart or self.samples == 0
        out = 0 if restart else 1 - self._latest
        previous = hdr if restart else self.targets[self._latest]
        self.samples = 1 if restart else self.samples + 1
        self.fullscreen.draw(
            self.fbos[out],
            {"u_weight": 1.0 / self.samples},
            {"u_hdr": hdr, "u_mean": previous},
            viewport=(0, 0, *self.size),
        )
        self._latest = out

    def read(self) -> np.ndarray:
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        self.fullscreen.release()
        for obj in (*self.fbos, *self.targets):
            obj.release()
