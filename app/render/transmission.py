"""The transmission pass: KHR_materials_transmission and KHR_materials_volume (RTR4 §14.5),
screen-space refraction of the opaque image behind a transmissive surface.

A part whose (first) layer has ``transmission`` > 0 is, like a blended part, left out of
the G-buffer and of the shadow maps' depth (the culler and the lighting pass see what is
behind it; under a shadowed light it tints the shadow pass's glass target) and
drawn here, after the lighting pass and the environment background and before the blend
pass. First the lighting pass's HDR image is copied into a texture with a mip chain (only
in a frame with a transmissive part); then each transmissive part is shaded forward by
glsl/passes/forward.frag with ``TRANSMISSION``: the lighting pass's ``surface_radiance``
with the diffuse base weighted by (1 - transmission), plus the transmitted term of
glsl/brdf/transmission.glsl (twin app/reference/transmission.py): the view ray refracted
into and out of a sphere of diameter the volume's thickness (straight on where
thin-walled), followed on screen to the opaque surface it meets (the G-buffer's depth) and
read from the copy there at the mip level of the rough lobe's footprint, times the
base colour, (1 - F) and Beer-Lambert's exp(-sigma d), plus each punctual light seen
through the surface (the transmitted GGX lobe about the light mirrored through the
surface, KHR_materials_transmission's BTDF, lit from the refracted ray's exit point). The
result replaces the pixel (no blending: the light behind is already in it), depth-tested
against the G-buffer's depth.

What it cannot see (docs/transmission.md measures it against the ray-caster's exact
refraction): anything not on screen or hidden behind another opaque surface at the exit
point's pixel, other transmissive or blended parts (one layer of glass, farthest first),
a far side other than a sphere's, internal reflections, shadows on the lights seen through
the glass, and caustics.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.gl.context import release_objects
from app.render.blend import BLEND_INPUTS, OverOpaqueTarget, draw_farthest_first, world_centre
from app.render.gbuffer import GBuffer
from app.render.inputs import LIGHTS, MATERIALS, ShadingContext
from app.render.lighting import LightingPass
from app.render.mesh_drawable import MeshDrawable
from app.scene.geometry import MeshPart

# forward.frag as the transmission pass, emission and occlusion compiled in as the blend
# pass's (GBUFFER_EMISSION selects layers.glsl's lookups; this pass writes no G-buffer).
TRANSMISSION_DEFINES = {"TRANSMISSION": 1, "GBUFFER_EMISSION": 1}


def transmissive(part: MeshPart) -> bool:
    """Whether the part is drawn by the transmission pass: ``transmission`` > 0 on its
    (first) layer, the one the pass shades (a transmissive part that is also alpha-blended
    is drawn here, opaque to what is behind but for the light it transmits)."""
    return float(part.layers[0].params.params.transmission) > 0.0


def transmission_defines(context: ShadingContext) -> dict[str, int]:
    """``TRANSMISSION_DEFINES`` plus the defines of the frame's inputs the pass reads
    (``BLEND_INPUTS``, as the blend pass), so a transmissive part is lit as an opaque one."""
    return {**TRANSMISSION_DEFINES, **context.only(*BLEND_INPUTS).defines()}


class TransmissionPass:
    """The transmissive parts of a frame, drawn over the lighting pass's HDR image."""

    def __init__(
        self, ctx: moderngl.Context, drawables: list[MeshDrawable], context: ShadingContext
    ) -> None:
        """``drawables``: ``forward_drawables`` of the transmissive parts, compiled with
        ``transmission_defines(context)``; ``context``: the lighting pass's inputs, of which
        the pass binds ``BLEND_INPUTS``."""
        context.require("the transmission pass", LIGHTS, MATERIALS)
        self.ctx = ctx
        self.context = context.only(*BLEND_INPUTS)
        self.drawables = drawables
        self._centres = [world_centre(d.part) for d in drawables]
        self.image: moderngl.Texture | None = None  # the opaque image with its mips
        self._source: moderngl.Framebuffer | None = None
        self._copy: moderngl.Framebuffer | None = None  # the copy's level 0
        self._target = OverOpaqueTarget(ctx)

    def _targets(
        self, hdr: moderngl.Texture, zbuffer: moderngl.Renderbuffer
    ) -> moderngl.Framebuffer:
        """The copy's texture (with a mip chain, trilinear) and the framebuffers of the
        HDR image (the copy's source) and of the HDR image with the G-buffer's depth (the
        draw's target), made again when either is new."""
        if self._target.attach(hdr, zbuffer):
            self._release_copy()
            self._source = self.ctx.framebuffer([hdr])
            image = self.ctx.texture(hdr.size, 4, dtype="f4")
            image.build_mipmaps()  # allocates the chain; filled each frame
            image.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            image.repeat_x = image.repeat_y = False
            self.image = image
            # a framebuffer-to-framebuffer blit keeps float32 (a copy into the texture
            # itself went through 8 bits per channel on llvmpipe: 0.3 read back 76/255)
            self._copy = self.ctx.framebuffer([image])
        assert self._target.fbo is not None
        return self._target.fbo

    def copy_opaque(self, hdr: moderngl.Texture, zbuffer: moderngl.Renderbuffer) -> None:
        """The opaque HDR image into ``image`` and its mip chain (box-filtered levels: the
        GL's glGenerateMipmap), which the fragments read at a roughness-dependent level."""
        self._targets(hdr, zbuffer)
        assert self._source is not None and self._copy is not None and self.image is not None
        self.ctx.copy_framebuffer(self._copy, self._source)
        self.image.build_mipmaps()

    def run(
        self,
        gbuffer: GBuffer,
        lighting: LightingPass,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """Copy the opaque image, then draw every transmissive part, farthest first, over
        ``lighting.hdr``."""
        ctx = self.ctx
        self.copy_opaque(lighting.hdr, gbuffer.zbuffer)
        fbo = self._targets(lighting.hdr, gbuffer.zbuffer)
        fbo.use()
        size = lighting.size
        ctx.viewport = (0, 0, *size)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        fbo.depth_mask = False  # tested against the opaque surfaces, never written
        unit = self.context.use()  # the copy on the next unit, the layers' maps after it
        assert self.image is not None
        self.image.use(location=unit)
        gbuffer.texture("depth").use(location=unit + 1)  # what lies behind: the blur's width
        draw_farthest_first(
            ctx,
            self.context,
            self.drawables,
            self._centres,
            view,
            proj,
            camera,
            size,
            unit + 2,
            {"u_transmission_image": unit, "u_transmission_depth": unit + 1},
        )
        fbo.depth_mask = True
        ctx.disable(moderngl.CULL_FACE)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def _release_copy(self) -> None:
        release_objects(self._source, self._copy, self.image)
        self._source = self._copy = self.image = None

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        self._release_copy()
        self._target.release()
