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

"sraa": ``SraaPass``, subpixel reconstruction antialiasing after Chajdas, McGuire &
Luebke, "Subpixel Reconstruction Antialiasing for Deferred Shading" (I3D 2011): the frame
is shaded once per pixel; a second G-buffer pass rasterises only geometry at
``SRAA_SAMPLES`` samples per pixel (a multisampled target; an analytic sphere ray-casts
each sample's coverage itself, gl_SampleMask), and each sample takes the shaded colour
of the neighbouring pixel whose centre saw its surface (glsl/passes/sraa.frag, written
here); the mean of the pixel's centre and its samples is resolved in linear HDR before
tone mapping.

"gbaa": ``GbaaPass``, geometric edge antialiasing after E. Persson, "Geometric Buffer
Antialiasing" (SIGGRAPH 2011) and Malan, "Edge Anti-aliasing by Post-Processing" (GPU
Pro, 2010): the G-buffer pass writes each pixel's distance to its surface's edge along
the four axis directions (the G-buffer's ``edge`` target: a mesh's triangle edges through a
geometry stage's barycentrics, an analytic sphere's silhouette from the ray's distance
inside it), and a resolve mixes each silhouette pixel's linear HDR colour with its
neighbour's across the edge by the area the edge gives it (glsl/passes/gbaa.frag,
written here), writing the display image there.
"""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.tonemaps import TONEMAPS
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw, bind_textures, set_uniforms
from app.gl.shaders import ShaderCache, supports
from app.reference.antialiasing import GBAA_SPILL, gbaa_saturation
from app.render.fullscreen import read_rgb
from app.render.gbuffer import GBuffer
from app.render.sample_geometry import SampleGeometry, SampleInputs

ANTIALIASING = ("none", "fxaa", "jitter", "sraa", "gbaa", "msaa")  # "msaa": app/render/msaa.py
SRAA_SAMPLES = 4  # the geometry samples per pixel (llvmpipe's only multisample count)
# A sample sees a neighbour's surface where their material ids agree and their view
# depths differ by at most this fraction of the sample's
SRAA_DEPTH_TOLERANCE = 0.1


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


def _display_with_depth(
    ctx: moderngl.Context,
    current: moderngl.Framebuffer | None,
    display: moderngl.Texture,
    depth: moderngl.Renderbuffer,
) -> moderngl.Framebuffer:
    """The framebuffer of ``display`` with a pass's marked ``depth`` attached, read-only
    (its z-test picks the marked pixels): ``current`` where it already draws into
    ``display``, else a new one (``current`` released)."""
    if current is not None and current.color_attachments[0] is display:
        return current
    if current is not None:
        current.release()
    fbo = ctx.framebuffer([display], depth)
    fbo.depth_mask = False
    return fbo


# The side of the blocks FXAA marks and filters: llvmpipe's rasteriser block (it shades a
# fragment shader's every branch for all 4x4 pixels of a block with any pixel in it).
FXAA_BLOCK = 4


class FxaaPass:
    """The display image (RGBA8, sRGB-encoded) filtered in place: its FXAA-class filtered
    image, alpha filtered with the colour. Luma is taken from the encoded values, as FXAA
    does: edges are found where they are seen. A copy of the image into ``source`` (the
    filter's input: bilinear, clamped; a blit), then two draws: the mark, one fragment per
    ``FXAA_BLOCK`` square block of pixels, writes 1 into ``marks`` where the block holds an
    edge pixel; the filter draws into the display image itself one point of the block's
    size per marked block (glsl/passes/fxaa_blocks.vert; the list of marked blocks read
    back from ``marks``), so that only those blocks run the search, and every other pixel
    keeps its bytes (a marked block's pixels that are no edge get their own bytes back).
    So whatever shows the post pass's target shows the filtered image."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        tuning: dict[str, float] | None = None,
    ):
        tuning = dict(tuning or {})  # FXAA_SUBPIX, FXAA_EDGE_THRESHOLD(_MIN): the bench's
        defines = {**tuning, "FXAA_BLOCK": FXAA_BLOCK}
        self.ctx, self.size = ctx, size
        self.grid = (-(-size[0] // FXAA_BLOCK), -(-size[1] // FXAA_BLOCK))
        self.mark = FullscreenDraw.of(
            ctx, shaders, "passes/fxaa.frag", {**defines, "FXAA_BLOCK_MARK": 1}
        )
        self.filter = shaders.program("passes/fxaa_blocks.vert", "passes/fxaa.frag", defines)
        self._blocks = ctx.buffer(reserve=4 * self.grid[0] * self.grid[1], dynamic=True)
        self._points = ctx.vertex_array(self.filter, [(self._blocks, "i", "a_block")])
        self.source = ctx.texture(size, 4, dtype="f1")
        self.source.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.source.repeat_x = self.source.repeat_y = False
        self._source_fbo = ctx.framebuffer([self.source])
        self.marks = ctx.texture(self.grid, 1, dtype="f1")
        self.marks.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._marks_fbo = ctx.framebuffer([self.marks])
        self._out: moderngl.Framebuffer | None = None  # the display image's

    def run(self, display: moderngl.Texture) -> None:
        """Filter ``display`` (RGBA8 of ``size``) in place."""
        self.mark_blocks(display)
        self.filter_blocks(display)

    def mark_blocks(self, display: moderngl.Texture) -> None:
        """``source``: a copy of ``display``; ``marks``: 1 at its blocks with an edge pixel."""
        ctx = self.ctx
        if self._out is None or self._out.color_attachments[0] is not display:
            if self._out is not None:
                self._out.release()
            self._out = ctx.framebuffer([display])
        ctx.copy_framebuffer(self._source_fbo, self._out)
        self.mark.draw(self._marks_fbo, {}, {"u_display": display}, viewport=(0, 0, *self.grid))
        ctx.viewport = (0, 0, *self.size)

    def filter_blocks(self, display: moderngl.Texture) -> None:
        """``display``'s blocks that ``marks`` names, filtered from ``source``."""
        ctx = self.ctx
        if self._out is None or self._out.color_attachments[0] is not display:
            raise ValueError("FxaaPass.filter_blocks: mark_blocks(display) first")
        # the marked blocks' list, read back: the filter waits for the mark in any case,
        # and the points' vertex stage (llvmpipe runs it on the submitting thread) then
        # takes the marked blocks alone, not every block of the grid
        blocks = np.flatnonzero(np.frombuffer(self.marks.read(alignment=1), np.uint8))
        if blocks.size == 0:
            return
        self._blocks.write(blocks.astype(np.int32).tobytes())
        self._out.use()
        self._out.scissor = None
        ctx.viewport = (0, 0, self.grid[0] * FXAA_BLOCK, self.grid[1] * FXAA_BLOCK)
        bind_textures(self.filter, {"u_display": self.source})
        set_uniforms(self.filter, {"u_grid": self.grid})
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.enable(moderngl.PROGRAM_POINT_SIZE)
        self._points.render(moderngl.POINTS, vertices=int(blocks.size))
        ctx.disable(moderngl.PROGRAM_POINT_SIZE)
        ctx.viewport = (0, 0, *self.size)

    def release(self) -> None:
        release_objects(
            self.mark,
            self._points,  # the program is the shader cache's
            self._blocks,
            self._out,
            self._source_fbo,
            self.source,
            self._marks_fbo,
            self.marks,
        )


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
        release_objects(*self.fbos, *self.targets)


class SraaPass:
    """Subpixel reconstruction (module docstring): ``run`` draws the opaque parts'
    geometry into ``samples`` by ``geometry`` (``SampleGeometry``, app/render/sample_geometry.py:
    of the multisampled G-buffer only RT2 read, view depth and material id per sample)
    and reconstructs each sample's colour from the pixel-centre frame's HDR image
    and RT2, in two draws (glsl/passes/sraa.frag): a mark that copies the image into
    ``target`` and marks the edge pixels (a sample on another surface than the centre)
    in a depth buffer, and the reconstruction z-tested to them. ``target`` holds the
    resolved linear HDR RGBA (the mean of the centre and the samples, alpha averaged with
    the colour)."""

    def __init__(self, inputs: SampleInputs) -> None:
        """``inputs``: the G-buffer pass's parts, material ids and maps, and the context,
        shader cache, size and layout they are drawn with (``SampleInputs``)."""
        ctx, shaders, size = inputs.ctx, inputs.shaders, inputs.size
        self.ctx, self.size = ctx, size
        defines = {"SAMPLES": SRAA_SAMPLES}
        self.mark = FullscreenDraw.of(ctx, shaders, "passes/sraa.frag", {**defines, "SRAA_MARK": 1})
        self.reconstruct = FullscreenDraw.of(
            ctx, shaders, "passes/sraa.frag", {**defines, "FAR_PLANE": 1}
        )
        self.target = ctx.texture(size, 4, dtype="f4")
        self.target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.geometry = SampleGeometry(inputs, SRAA_SAMPLES, ("depth",))
        self.samples = self.geometry.targets  # RT2 per sample: view depth, material id
        self.fbo = self.geometry.mark_into(self.target)

    def run(
        self,
        gbuffer: GBuffer,
        hdr: moderngl.Texture,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """The geometry samples of the camera (``view``, ``proj``, ``camera``: the frame
        ``gbuffer`` and ``hdr`` were drawn with), then the reconstruction into ``target``."""
        self.geometry.draw(view, proj, camera)
        uniforms = {"u_depth_tolerance": SRAA_DEPTH_TOLERANCE}
        textures = {"u_hdr": hdr, "u_depth": gbuffer.depth, "u_samples": self.samples.depth}
        viewport = (0, 0, *self.size)
        self.geometry.mark_then(
            self.mark, uniforms, textures,
            lambda: self.reconstruct.draw(
                self.fbo, uniforms, textures, viewport=viewport, depth_func=">"
            ),
        )  # fmt: skip

    def read(self) -> np.ndarray:
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        for obj in (self.geometry, self.mark, self.reconstruct, self.target):
            obj.release()


# Contexts whose dFdx and dFdy were found fine (or not), by id and renderer
_FINE_DERIVATIVES: dict[tuple[int, str], bool] = {}


def quad_neighbour_defines(ctx: moderngl.Context, shaders: ShaderCache) -> dict[str, int]:
    """The defines with which gbaa's draws take a 2x2 quad's inner neighbour from the
    derivatives (passes/gbaa.frag QUAD_NEIGHBOURS): with ``FINE_DERIVATIVES``, dFdxFine
    and dFdyFine (fine by definition, no draw to find out), where the GL supports what
    the define needs (app/gl/shaders.py ``NEEDS``: GLSL 4.00 and
    GL_ARB_derivative_control); else with dFdx and dFdy where ``fine_derivatives`` finds
    them fine; none (five fetches) where neither holds."""
    if supports(ctx, "FINE_DERIVATIVES"):
        return {"QUAD_NEIGHBOURS": 1, "FINE_DERIVATIVES": 1}
    if fine_derivatives(ctx, shaders):
        return {"QUAD_NEIGHBOURS": 1}
    return {}


def fine_derivatives(ctx: moderngl.Context, shaders: ShaderCache) -> bool:
    """Whether ``ctx``'s dFdx and dFdy are fine, each row and column of a 2x2 quad its own
    difference (llvmpipe's are; GLSL 3.30 allows coarse ones, and the fine built-ins need
    GL 4.0 or an extension): drawn once on a 4x4 image (glsl/passes/gbaa_probe.frag) and
    remembered for the context."""
    key = (id(ctx), str(ctx.info.get("GL_RENDERER")))
    if key not in _FINE_DERIVATIVES:
        target = ctx.texture((4, 4), 4, dtype="f4")
        fbo = ctx.framebuffer([target])
        probe = FullscreenDraw.of(ctx, shaders, "passes/gbaa_probe.frag")
        try:
            probe.draw(fbo, viewport=(0, 0, 4, 4))
            texels = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
            ddx, ddy, x, y = texels.reshape(-1, 4).T
            _FINE_DERIVATIVES[key] = bool(np.all(ddx == y) and np.all(ddy == x))
        finally:
            release_objects(probe, fbo, target)
    return _FINE_DERIVATIVES[key]


# The most window rectangles gbaa's draws cover separately (glsl/passes/gbaa_rects.vert's
# uniform array); more are drawn as their union.
GBAA_MAX_RECTS = 16
Rect = tuple[int, int, int, int]  # window pixels x0, y0, x1, y1 (x1, y1 past the last)


def box_window_rects(
    boxes: np.ndarray, view: np.ndarray, proj: np.ndarray, size: tuple[int, int]
) -> np.ndarray | None:
    """(K, 4) window rectangles (float pixels x0, y0, x1, y1) of world-space box corners
    ``boxes`` (K, 8, 4); None where a corner lies behind the camera (its projection is not
    bounded by the others')."""
    clip = boxes @ (proj @ view).T
    if np.any(clip[..., 3] <= 1e-9):
        return None
    window = (clip[..., :2] / clip[..., 3:4] * 0.5 + 0.5) * np.asarray(size, np.float64)
    return np.concatenate([window.min(axis=1), window.max(axis=1)], axis=1)


def sphere_window_rects(
    spheres: np.ndarray, view: np.ndarray, proj: np.ndarray, size: tuple[int, int]
) -> np.ndarray | None:
    """(S, 4) window rectangles (float pixels x0, y0, x1, y1) of the silhouettes of
    ``spheres`` (S, 4: world centre, radius): along each window axis, the two planes
    through the eye that touch the sphere, found in the plane of that axis and the view
    direction (their tangent points there project to the silhouette's extremes: the
    projection's x depends on view x and z alone, y on y and z); None where the eye lies
    within a sphere's slab or a tangent point lies behind it."""
    c = spheres[:, :3] @ view[:3, :3].T + view[:3, 3]
    r = spheres[:, 3]
    out = np.empty((len(spheres), 4))
    for axis in (0, 1):
        a, z = c[:, axis], c[:, 2]
        d2 = a * a + z * z
        tangent2 = d2 - r * r
        if np.any(tangent2 <= 1e-12 * d2):
            return None
        ends = []
        for side in (-1.0, 1.0):
            # the tangent point: (L^2 C + side L r C_perp) / d^2, L the tangent's length
            s = side * np.sqrt(tangent2) * r
            ta, tz = (a * tangent2 - s * z) / d2, (z * tangent2 + s * a) / d2
            if np.any(tz >= -1e-9):
                return None
            p = c.copy()
            p[:, axis], p[:, 2] = ta, tz
            clip = p @ proj[:, :3].T + proj[:, 3]
            ends.append((clip[:, axis] / clip[:, 3] * 0.5 + 0.5) * size[axis])
        out[:, axis], out[:, axis + 2] = np.minimum(*ends), np.maximum(*ends)
    return out


def merged_rects(rects: list[Rect]) -> list[Rect]:
    """``rects`` with every two that overlap replaced by the rectangle around both, until
    none overlap (a pixel drawn twice is shaded twice)."""
    out = list(rects)
    merged = True
    while merged:
        merged = False
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                a, b = out[i], out[j]
                if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                    out[i] = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))
                    del out[j]
                    merged = True
                    break
            if merged:
                break
    return out


class PartRects:
    """The window rectangles of a frame's opaque parts, for the draws that only the pixels
    their samples see need (gbaa's mark and resolve, msaa's mark): ``boxes``, (K, 8, 4)
    world-space corners of the mesh parts' bounding boxes; ``spheres``, (S, 4) world
    centre and radius of the analytic spheres, whose rectangle is their silhouette's (a
    box's corners project well outside a sphere's). None: the whole image."""

    def __init__(
        self, size: tuple[int, int], boxes: np.ndarray | None, spheres: np.ndarray | None
    ) -> None:
        self.size = size
        self.boxes = None if boxes is None else np.asarray(boxes, np.float64).reshape(-1, 8, 4)
        self.spheres = np.zeros((0, 4)) if spheres is None else np.asarray(spheres, np.float64)
        self._rects_for: tuple[bytes, list[Rect]] | None = None  # (camera, rects())

    def rects(self, view: np.ndarray, proj: np.ndarray) -> list[Rect]:
        """The window rectangles (x0, y0, x1, y1) of the opaque parts seen through
        ``view`` and ``proj``, a pixel wider each way, clamped to the image and merged
        where they overlap; the whole image where a part's cannot be bounded (without
        ``boxes``, or a part behind or around the camera); none without parts. Kept for
        the last camera (a frame's Python time counts: the bench draws 1.3 ms frames)."""
        view, proj = np.asarray(view, np.float64), np.asarray(proj, np.float64)
        key = view.tobytes() + proj.tobytes()
        if self._rects_for is not None and self._rects_for[0] == key:
            return self._rects_for[1]
        w, h = self.size
        rects = [(0, 0, w, h)]
        if self.boxes is not None:
            found = [box_window_rects(self.boxes, view, proj, self.size),
                     sphere_window_rects(self.spheres, view, proj, self.size)]  # fmt: skip
            if all(f is not None for f in found):
                bounds = np.concatenate(found)
                lo = np.clip(np.floor(bounds[:, :2]) - 1, 0, (w, h)).astype(int)
                hi = np.clip(np.ceil(bounds[:, 2:]) + 1, 0, (w, h)).astype(int)
                keep = np.all(hi > lo, axis=1)
                rects = merged_rects([tuple(r) for r in np.c_[lo, hi][keep].tolist()])
                if len(rects) > GBAA_MAX_RECTS:
                    rects = [(min(q[0] for q in rects), min(q[1] for q in rects),
                              max(q[2] for q in rects), max(q[3] for q in rects))]  # fmt: skip
        self._rects_for = (key, rects)
        return rects


class GbaaPass:
    """Geometric edge antialiasing (module docstring): reads the G-buffer's RT2
    (surfaces) and ``edge`` target (distances to the surface's edge) and the frame's
    linear HDR image, and writes the display image's silhouette pixels, resolved, over
    the post pass's image. Two draws (glsl/passes/gbaa.frag): ``mark`` writes window
    depth 0 into ``depth`` where a pixel and a 4-neighbour hold different surfaces (1 at
    the other surface pixels, 0.5 at the other background ones), and ``resolve`` runs at
    depth 0.25 z-tested (">") to those pixels, so that only blocks of pixels with a
    silhouette run it (llvmpipe shades every branch for its whole block). The other
    pixels keep post's bytes. The resolve reads the HDR image at
    marked pixels only (a neighbour it mixes in holds another surface, so is marked):
    where the lighting pass wrote the display image it wrote the surfaces' radiance too
    (``Renderer.run_lighting``), and the background's is given as a uniform.
    ``tonemap_code`` and ``straight_alpha`` are post's. Both draws cover the window
    rectangles of the opaque parts and a pixel around them (no silhouette lies outside;
    glsl/passes/gbaa_rects.vert), merged where they overlap (``PartRects`` of ``boxes``
    and ``spheres``).
    ``exact`` (GBAA_EXACT, the renderer's): each covered area the box filter of the
    edge's half-plane from its distances along both axes, exact at the pixel's corners
    (``box_coverage``), and each edge pixel's own part moved to its area mean along the
    axes whose neighbours hold its surface (``along_edge``); False: the area along the
    nearest axis alone (Persson's, 0.5 + d), the baseline docs/antialiasing.md measures
    the exact areas against.
    ``interior`` (``render.gbaa_interior``): a third draw (GBAA_CORRECT), after the mark
    at depth 0.75 z-tested ("<") to the pixels whose 4 neighbours hold their own surface,
    writes each one's centre radiance moved to its area mean (``interior_radiance``, a
    5-point second-order correction; docs/accuracy.md, "Every pixel") over post's bytes,
    from the HDR image alone; a neighbour past ``spill`` (``GBAA_SPILL`` times the tone
    map's white, app/reference/antialiasing.py) counts as the pixel's own."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        tonemap_code: int,
        straight_alpha: bool = False,
        boxes: np.ndarray | None = None,
        spheres: np.ndarray | None = None,
        exact: bool = True,
        interior: bool = False,
    ) -> None:
        self.ctx, self.size, self.exact, self.interior = ctx, size, exact, interior
        self.part_rects = PartRects(size, boxes, spheres)
        defines: dict[str, object] = {"TONEMAP": tonemap_code, "GBAA_MAX_RECTS": GBAA_MAX_RECTS}
        if straight_alpha:
            defines["STRAIGHT_ALPHA"] = 1
        defines.update(quad_neighbour_defines(ctx, shaders))  # three fetches each, not five
        vertex, fragment = "passes/gbaa_rects.vert", "passes/gbaa.frag"
        defines["GBAA_EXACT"] = int(exact)
        # the mark writes window depth 0 (silhouettes), 1 (interior surface pixels) or 0.5
        # (the background elsewhere): the resolve at 0.25 (">") and the correction at 0.75
        # ("<") each z-test to their own pixels
        self.marker = shaders.program(vertex, fragment, {**defines, "GBAA_MARK": 1})
        self.resolver = shaders.program(vertex, fragment, {**defines, "RECT_DEPTH": -0.5})
        programs = [self.marker, self.resolver]
        if interior:
            self.corrector = shaders.program(
                vertex, fragment, {**defines, "GBAA_CORRECT": 1, "RECT_DEPTH": 0.5}
            )
            programs.append(self.corrector)
        # the radiance at exposure 0 past which a neighbour's 1/24 alone is white
        self.spill = GBAA_SPILL * gbaa_saturation(TONEMAPS[tonemap_code])
        self._vaos = [ctx.vertex_array(p, []) for p in programs]
        self.depth = ctx.depth_renderbuffer(size)
        self._out: moderngl.Framebuffer | None = None  # the display image + ``depth``
        self._rects: list[Rect] = []
        self._ndc: tuple[list[Rect] | None, bytes] = (None, b"")  # (rects, u_rects)

    def rects(self, view: np.ndarray, proj: np.ndarray) -> list[Rect]:
        """The window rectangles the draws cover (``PartRects.rects``)."""
        return self.part_rects.rects(view, proj)

    def _draw(
        self,
        which: int,
        uniforms: dict[str, object],
        textures: dict[str, moderngl.Texture],
        depth_func: str,
    ) -> None:
        """Draw program ``which`` (0 the mark, 1 the resolve, 2 the interior correction)
        over ``_rects`` into ``_out`` with the depth test ``depth_func``."""
        if not self._rects:
            return
        program = self._vaos[which].program
        w, h = self.size
        if self._ndc[0] != self._rects:  # the rectangles in NDC, once for both draws
            ndc = np.zeros((GBAA_MAX_RECTS, 4), np.float32)
            ndc[: len(self._rects)] = np.asarray(self._rects, np.float64) / (w, h, w, h) * 2 - 1
            self._ndc = (self._rects, ndc.tobytes())
        ctx = self.ctx
        self._out.use()
        self._out.scissor = None
        ctx.viewport = (0, 0, w, h)
        bind_textures(program, textures)
        set_uniforms(program, {**uniforms, "u_rects": self._ndc[1]})
        ctx.disable(moderngl.BLEND)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = depth_func
        self._vaos[which].render(moderngl.TRIANGLES, vertices=6 * len(self._rects))
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"

    def mark(
        self,
        gbuffer: GBuffer,
        display: moderngl.Texture,
        rects: list[Rect],
        hdr: moderngl.Texture | None = None,
        exposure_ev: float = 0.0,
        background: np.ndarray | None = None,
    ) -> None:
        """``depth``: 0 at the silhouette pixels of ``gbuffer``'s frame inside ``rects``
        (``rects()``: the resolve's then too), 1 at their other surface pixels and 0.5 at
        their other background pixels. Drawn through the
        framebuffer the resolve draws into, ``display`` (the post pass's image) with
        ``depth``, its colour writes off: one framebuffer for every draw, which llvmpipe
        then runs without a flush between them. With ``interior`` the correction draw
        then writes the interior pixels' display value (colour and alpha) from ``hdr`` and
        ``exposure_ev`` (``background`` is the resolve's: no neighbour there is one)."""
        self._rects = list(rects)
        self._out = _display_with_depth(self.ctx, self._out, display, self.depth)
        self._out.depth_mask = True
        self._out.color_mask = (False, False, False, False)
        self._draw(0, {}, {"u_depth": gbuffer.depth}, "1")
        self._out.depth_mask = False
        self._out.color_mask = (True, True, True, True)
        if self.interior:  # the interior pixels' colour (and alpha 1, post's there)
            scale = 2.0**exposure_ev
            uniforms = {"u_exposure": scale, "u_spill": self.spill / scale}
            self._draw(2, uniforms, {"u_hdr": hdr}, "<")

    @staticmethod
    def _uniforms(exposure_ev: float, background: np.ndarray | None) -> dict[str, object]:
        """The resolve's uniforms: the exposure and the background's radiance (where
        ``background`` is given: the HDR image then holds the surface pixels alone)."""
        rgba = np.zeros(4) if background is None else np.resize(np.asarray(background), 4)
        if background is not None and len(background) == 3:
            rgba[3] = 1.0
        return {
            "u_exposure": 2.0**exposure_ev,
            "u_uniform_background": 0.0 if background is None else 1.0,
            "u_background": tuple(float(x) for x in rgba),
        }

    def resolve(
        self,
        gbuffer: GBuffer,
        hdr: moderngl.Texture,
        display: moderngl.Texture,
        exposure_ev: float,
        background: np.ndarray | None = None,
    ) -> None:
        """Resolve the marked pixels of ``gbuffer``'s frame from ``hdr`` (its linear HDR
        image, ``size``) into ``display`` (post's RGBA8 image of it). ``background``: the
        RGBA radiance of every pixel without a surface, where ``hdr`` holds only the
        marked surface pixels (None: ``hdr`` holds every pixel)."""
        self._out = _display_with_depth(self.ctx, self._out, display, self.depth)
        textures = {"u_depth": gbuffer.depth, "u_edge": gbuffer.edge, "u_hdr": hdr}
        self._draw(1, self._uniforms(exposure_ev, background), textures, ">")

    def release(self) -> None:
        release_objects(*self._vaos, self._out, self.depth)
