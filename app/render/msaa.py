"""Multisampled G-buffer with per-sample shading at edges: ``render.antialiasing = "msaa"``
(docs/antialiasing.md).

The deferred MSAA of A. Lauritzen, "Deferred Rendering for Current and Future Rendering
Pipelines" (SIGGRAPH 2010 course), written for this project: the G-buffer is rasterised
at ``MSAA_SAMPLES`` samples per pixel (every target of the frame's ``GBufferLayout``,
multisampled, from the one declaration ``GBUFFER_TARGETS``; the fragment stage runs once
per pixel and its values go to every sample it covers, an analytic sphere's coverage
ray-cast per sample as ``"sraa"``'s geometry samples are); a pixel whose samples hold
different surfaces (``glsl/passes/msaa.frag``: the background, another material id, a
view depth ``MSAA_DEPTH_TOLERANCE`` apart, a normal ``MSAA_NORMAL_TOLERANCE`` apart) is
shaded once per sample by the lighting pass's own program compiled with
``GBUFFER_SAMPLES`` (``glsl/passes/lighting.frag``: the decode reads sample
``gbuffer_sample`` of ``sampler2DMS`` targets, one lighting body), and its colour is the
mean of its samples' radiance (a box over the pixel) in linear HDR, before exposure and
tone mapping, as the supersampling resolve averages. Every other pixel keeps the frame
shaded once per pixel at its centre: the one-sample G-buffer pass and the lighting pass
run as in ``"none"`` (every other pass reads their targets), and the multisampled pass
is drawn besides, so a pixel inside a surface keeps the aliased frame's value exactly.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw, bind_textures, set_uniforms
from app.reference.msaa import MSAA_DEPTH_TOLERANCE, MSAA_NORMAL_TOLERANCE
from app.render.antialias import PartRects
from app.render.fullscreen import read_rgb
from app.render.gbuffer import GBuffer
from app.render.inputs import TILES, GBufferInput, ShadingContext, bind_camera
from app.render.lighting import LightingPass
from app.render.sample_geometry import SampleGeometry, SampleInputs

MSAA_SAMPLES = 4  # samples per pixel (llvmpipe's only multisample count)
# Two samples hold one surface where their material ids agree, their view depths lie
# within MSAA_DEPTH_TOLERANCE (1 %) of the nearer one's and their octahedral normals
# within MSAA_NORMAL_TOLERANCE (0.02, about 1 degree) in each coordinate: two triangles of
# one smooth mesh meet there without an edge to shade per sample; a crease or a
# silhouette does not. Declared with the twin (app/reference/msaa.py).


class MsaaPass:
    """The multisampled G-buffer and the per-sample shading of its edge pixels (module
    docstring). ``run`` draws the opaque parts into ``samples`` by ``geometry``
    (``SampleGeometry``, app/render/sample_geometry.py: every target of the multisampled
    G-buffer read), then two draws into ``target`` (linear HDR RGBA): the mark
    (glsl/passes/msaa.frag; over ``rects`` alone, the rest blitted and unmarked) copies
    the frame's HDR image and writes window depth 0 into ``geometry.edges`` where a
    pixel's samples differ; the lighting programs (``shading``,
    one per model group, each adding its own samples' share, the first the background
    samples') run z-tested to those pixels.
    ``shading``: the frame's shader inputs (the lighting pass's) less the tile culler (its
    tiles' depth bounds are the pixel centres'; an edge pixel loops over every light),
    the multisampled G-buffer in place of the G-buffer."""

    def __init__(
        self,
        inputs: SampleInputs,
        shading: ShadingContext,
        terms: str,
        form: str,
        rects: PartRects | None = None,
    ) -> None:
        """``inputs``: the G-buffer pass's parts, material ids and maps, and the context,
        shader cache, size and layout they are drawn with (``SampleInputs``); ``terms``,
        ``form``: the lighting pass's. ``rects``: the window rectangles of the parts
        (gbaa's), which the mark covers alone (no sample outside them sees a surface);
        None: the whole image."""
        ctx, shaders, size = inputs.ctx, inputs.shaders, inputs.size
        self.ctx, self.size, self.rects = ctx, size, rects
        self._hdr: tuple[moderngl.Texture, moderngl.Framebuffer] | None = None  # a blit's source
        self.geometry = SampleGeometry(inputs, MSAA_SAMPLES)  # every target of the layout read
        self.samples = self.geometry.targets
        roles = [role for role in shading.roles if role != TILES]
        context = shading.only(*roles).with_inputs(GBufferInput(self.samples))  # type: ignore[arg-type]
        self.lighting = LightingPass(ctx, shaders, size, context, terms, form=form)
        self.mark = FullscreenDraw.of(ctx, shaders, "passes/msaa.frag", {"SAMPLES": MSAA_SAMPLES})
        self.target = self.lighting.hdr  # the lighting pass's own HDR target
        self.fbo = self.geometry.mark_into(self.target)

    def run(
        self,
        gbuffer: GBuffer,
        hdr: moderngl.Texture,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
        background: np.ndarray,
    ) -> None:
        """The multisampled G-buffer of the camera (``view``, ``proj``, ``camera``: the
        frame ``gbuffer`` and ``hdr`` were drawn with), then ``target``: ``hdr`` with its
        edge pixels shaded per sample. ``background``: the frame's RGB or RGBA background
        radiance (a sample without a surface takes a background pixel's beside it)."""
        self.geometry.draw(view, proj, camera)
        tolerances = {
            "u_depth_tolerance": MSAA_DEPTH_TOLERANCE,
            "u_normal_tolerance": MSAA_NORMAL_TOLERANCE,
        }
        textures = {
            "u_hdr": hdr,
            "u_depth": gbuffer.depth,
            "u_samples": self.samples.depth,
            "u_normals": self.samples.normal,
        }
        rects = None if self.rects is None else self.rects.rects(view, proj)
        if rects is not None:
            # every pixel outside the rectangles: hdr's value, unmarked (the mark's output
            # there); a blit and a clear, not ten fetches a pixel
            if self._hdr is None or self._hdr[0] is not hdr:
                self._release_hdr()
                self._hdr = (hdr, self.ctx.framebuffer([hdr]))
            self.fbo.clear(depth=1.0)
            self.ctx.copy_framebuffer(self.fbo, self._hdr[1])
        self.geometry.mark_then(
            self.mark,
            tolerances,
            textures,
            lambda: self.shade(gbuffer, hdr, camera, background),
            rects,
        )

    def shade(
        self,
        gbuffer: GBuffer,
        hdr: moderngl.Texture,
        camera: CameraFrame,
        background: np.ndarray,
    ) -> None:
        """The lighting programs at the marked pixels of ``target`` (``run``)."""
        rgba = np.resize(np.asarray(background, np.float64), 4)
        if len(background) == 3:
            rgba[3] = 1.0
        context = self.lighting.context
        unit = context.use()
        for i, draw in enumerate(self.lighting.draws):
            program = draw.program
            context.bind(program)
            bind_camera(program, camera)
            bind_textures(program, {"u_msaa_hdr": hdr, "u_msaa_centre_depth": gbuffer.depth}, unit)
            set_uniforms(program, {"u_msaa_background": tuple(float(x) for x in rgba)})
            # the first group's share and the background's replace the copy, every other
            # group's share is added
            draw.draw(self.fbo, viewport=(0, 0, *self.size), depth_func=">", add=i > 0)

    def read(self) -> np.ndarray:
        return read_rgb(self.fbo, self.size, "f4")

    def _release_hdr(self) -> None:
        if self._hdr is not None:
            release_objects(self._hdr[1])
            self._hdr = None

    def release(self) -> None:
        self._release_hdr()
        for obj in (self.geometry, self.mark, self.lighting):
            obj.release()
