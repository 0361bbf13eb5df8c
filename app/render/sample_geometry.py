"""The multisampled geometry pass that ``"sraa"`` and ``"msaa"`` share (docs/antialiasing.md).

Both draw the frame's opaque parts a second time into multisampled G-buffer targets
(``SampleGBuffer``) by a ``GBufferPass`` compiled with ``GBUFFER_SAMPLE_MASK`` (an
analytic sphere ray-casts each sample's coverage itself and writes it to
``gl_SampleMask``, from the GL's own sample positions, ``sample_positions``), then mark
the pixels whose samples differ in a depth buffer (window depth 0) and draw their own
resolve z-tested to the marked pixels only. ``SampleGeometry`` is that contract, once:
the targets, the pass, the positions it is told, and the mark-then-resolve sequence.
What differs between the two is a parameter: ``read``, the targets a resolve samples
(SRAA's reconstruction RT2 alone, MSAA's per-sample shading every target). What both take
from the renderer is one value, ``SampleInputs``: the opaque parts as the frame's
G-buffer pass draws them, declared once so that a new input is one field, not an edit of
each pass's parameters.
"""

from __future__ import annotations

import ctypes
import dataclasses
from collections.abc import Callable, Collection, Mapping, Sequence

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import GBUFFER_TARGETS, STORAGE_DTYPES, GBufferLayout
from app.gl.context import gl_function, release_objects
from app.gl.fullscreen import FullscreenDraw, Textures
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBufferPass
from app.render.texture_upload import TextureUploads
from app.scene.geometry import MeshPart

_GL_SAMPLE_POSITION = 0x8E50


@dataclasses.dataclass(frozen=True, eq=False)
class SampleInputs:
    """What a pass that draws the frame's opaque parts again, into multisampled targets of
    its own, takes from the renderer (``Renderer._sample_inputs``): ``SraaPass``'s and
    ``MsaaPass``'s ``SampleGeometry`` draw exactly what the G-buffer pass drew, so these
    are that pass's. ``ctx``, ``shaders``: the renderer's context and shader cache;
    ``size``: the render size (the G-buffer's); ``layout``: the G-buffer's targets
    (``GBufferLayout``), which the samples' targets and programs follow; ``parts``,
    ``material_ids``: the parts the G-buffer pass draws (all but the blended and
    transmissive ones) and their rows of the material table, one per layer;
    ``uploads``: the G-buffer pass's material maps, drawn with rather than uploaded
    again (None: the samples' pass uploads its own). Compared by identity (it holds a
    context and parts' arrays)."""

    ctx: moderngl.Context
    shaders: ShaderCache
    size: tuple[int, int]
    layout: GBufferLayout
    parts: list[MeshPart]
    material_ids: list[list[int]]
    uploads: TextureUploads | None = None


def sample_positions(ctx: moderngl.Context, fbo: moderngl.Framebuffer) -> np.ndarray:
    """(samples, 2) positions of ``fbo``'s samples inside a pixel, in pixels from its
    lower-left corner, as the GL rasterises them (glGetMultisamplefv)."""
    get = gl_function(ctx, "glGetMultisamplefv", [ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p])
    fbo.use()
    out = np.zeros(2, np.float32)
    positions = []
    for i in range(fbo.samples):
        get(_GL_SAMPLE_POSITION, i, out.ctypes.data)
        positions.append(out.copy())
    return np.array(positions)


class SampleGBuffer:
    """The G-buffer's targets multisampled, drawn by a ``GBufferPass`` as a ``GBuffer``
    is: each target of ``layout`` named in ``read`` (default: every one) a multisampled
    texture of its storage (``GBUFFER_TARGETS``' declaration under the layout's
    encoding), an attribute by the target's name as ``GBuffer``'s; every other target
    (the pass writes them all) a one-channel 8-bit multisampled renderbuffer, never read
    (a quarter of the bytes of RG32F), its attribute None; and a multisampled z-buffer.
    Decoded through ``GBufferInput`` as a ``GBuffer`` is (``defines`` adds
    ``GBUFFER_SAMPLES``: the decode's samplers are then ``sampler2DMS``)."""

    def __init__(
        self,
        ctx: moderngl.Context,
        size: tuple[int, int],
        layout: GBufferLayout,
        samples: int,
        read: Collection[str] | None = None,
    ) -> None:
        self.size, self.layout, self.samples = size, layout, samples
        self._attachments: list[moderngl.Texture | moderngl.Renderbuffer] = []
        self._by_name: dict[str, moderngl.Texture] = {}
        for target, channels in layout.targets():
            if read is None or target.name in read:
                dtype = STORAGE_DTYPES[layout.storage(target)]
                tex = ctx.texture(size, channels, dtype=dtype, samples=samples)
                self._by_name[target.name] = tex
                self._attachments.append(tex)
            else:
                self._attachments.append(ctx.renderbuffer(size, 1, samples=samples, dtype="f1"))
        for target in GBUFFER_TARGETS:
            setattr(self, target.name, self._by_name.get(target.name))
        self.zbuffer = ctx.depth_renderbuffer(size, samples=samples)
        self.fbo = ctx.framebuffer(self._attachments, self.zbuffer)
        # RT2 and the z-test, as GBuffer clears them (every drawn sample writes every target)
        self.clear_fbo = ctx.framebuffer([self._by_name["depth"]], self.zbuffer)

    def clear(self) -> None:
        """No surface in any sample (RT2's depth 0), the far z."""
        self.clear_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def defines(self) -> dict[str, int]:
        return {**self.layout.defines(), "GBUFFER_SAMPLES": self.samples}

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        return [(t.glsl_name, self._by_name[t.name]) for t, _ in self.layout.targets()]

    def release(self) -> None:
        release_objects(self.fbo, self.clear_fbo, *self._attachments, self.zbuffer)


class SampleGeometry:
    """The opaque parts of ``inputs`` (``SampleInputs``: the frame's G-buffer pass's parts,
    material ids and maps) drawn at ``samples`` samples per pixel into ``targets``
    (``SampleGBuffer``, its ``read`` targets sampled) by ``gbuffer_pass`` (a ``GBufferPass``
    with ``GBUFFER_SAMPLE_MASK``), and the edge marks: ``fbo`` (``mark_into``) draws into
    the owner's target with ``edges``, the depth buffer a mark writes window depth 0 into
    where a pixel's samples differ."""

    def __init__(
        self, inputs: SampleInputs, samples: int, read: Collection[str] | None = None
    ) -> None:
        ctx, layout = inputs.ctx, inputs.layout
        self.ctx, self.size = ctx, inputs.size
        self.targets = SampleGBuffer(ctx, inputs.size, layout, samples, read)
        defines = {**layout.defines(), "GBUFFER_SAMPLE_MASK": samples}
        self.gbuffer_pass = GBufferPass(
            ctx, inputs.shaders, inputs.parts, inputs.material_ids, None, defines, inputs.uploads
        )
        self.positions = sample_positions(ctx, self.targets.fbo).astype(np.float32)
        self.edges = ctx.depth_renderbuffer(inputs.size)
        self.fbo: moderngl.Framebuffer | None = None

    def mark_into(self, target: moderngl.Texture) -> moderngl.Framebuffer:
        """``fbo``, made once: ``target`` (the owner's linear HDR RGBA texture, not
        released here; MSAA's is its lighting pass's, which reads ``targets``) with
        ``edges`` as its depth."""
        self.fbo = self.ctx.framebuffer([target], self.edges)
        return self.fbo

    def refresh(self, material_ids: list[list[int]]) -> None:
        """A restyle's new material ids (``app.frame.restyle``: the same parts, new rows),
        one list per part as ``SampleInputs.material_ids``: the samples' RT2 ids are
        matched against the pixel-centre frame's, so they follow the G-buffer pass's."""
        for drawable, ids in zip(self.gbuffer_pass.drawables, material_ids, strict=True):
            drawable.material_ids = ids

    def draw(self, view: np.ndarray, proj: np.ndarray, camera: CameraFrame) -> None:
        """The samples of the camera (``view``, ``proj``, ``camera``), each program told
        the GL's sample positions first."""
        positions = self.positions.tobytes()
        for d in self.gbuffer_pass.drawables:
            if "u_sample_positions" in d.uniforms:  # a shader cache may share the program
                d.program["u_sample_positions"].write(positions)
        self.gbuffer_pass.run(self.targets, view, proj, camera)

    def mark_then(
        self,
        mark: FullscreenDraw,
        uniforms: Mapping[str, object],
        textures: Textures,
        resolve: Callable[[], None],
        rects: Sequence[tuple[int, int, int, int]] | None = None,
    ) -> None:
        """``mark`` drawn over all of ``fbo`` (its every fragment's depth written,
        unconditionally: 0 at an edge pixel, 1 elsewhere), then ``resolve`` with
        ``edges`` read-only, for draws z-tested (">") to the marked pixels. ``rects``:
        the window rectangles (x0, y0, x1, y1) the mark covers instead, each drawn as
        the viewport (its fragments keep their window positions); the caller has
        written every pixel outside them (the target's colour, ``edges``' depth 1)."""
        assert self.fbo is not None, "mark_into(target) first"
        self.fbo.depth_mask = True
        for x0, y0, x1, y1 in [(0, 0, *self.size)] if rects is None else rects:
            viewport = (x0, y0, x1 - x0, y1 - y0)
            mark.draw(self.fbo, uniforms, textures, viewport=viewport, depth_func="1")
        self.ctx.viewport = (0, 0, *self.size)
        self.fbo.depth_mask = False
        resolve()
        self.fbo.depth_mask = True

    def release(self) -> None:
        release_objects(self.gbuffer_pass, self.targets, self.fbo, self.edges)
