"""The blend pass: glTF 2.0 alphaMode BLEND, shaded forward and composited after lighting.

A G-buffer holds one surface per pixel, so it cannot blend. Blended parts are therefore
left out of the G-buffer pass (the culler and the lighting pass see what is behind them)
and drawn here, after the lighting pass, into its HDR image: each fragment evaluates the
full outgoing radiance with the lighting pass's own ``surface_radiance``
(glsl/lights/shading.glsl, from glsl/passes/forward.frag with ``ALPHA_BLEND``: every
light with its shadow map, the image-based light, emission, occlusion) and the
fixed-function blend composites it "over" what is there:

    C = a C_src + (1 - a) C_dst        (Porter and Duff, 1984, "Compositing Digital Images")

with ``a`` the glTF coverage (alpha factor x base colour map's A x COLOR_0's A). The depth
test reads the G-buffer's own depth buffer (attached read-only: no depth is written), so a
blended part behind an opaque surface is hidden, and blended parts never hide each other.

What is approximated (the usual real-time compromise, RTR4 §5.5): parts are sorted back to
front by the view depth of their bounding box's centre, once per frame; there is no sort
of the triangles within a part and no order-independent transparency, so two interpenetrating
blended parts, or a blended part that overlaps itself, composite in an order that can be
wrong where they cross. An open (two-sided) part draws its back faces, then its front
faces; a closed part only its front faces, as the G-buffer pass culls it. Blended parts
receive shadows but cast none (the shadow pass draws the opaque parts only).
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.models import BRDF_TERMS
from app.frame.camera import gl_bytes
from app.frame.materials import MaterialTable
from app.gl.context import release_objects
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer
from app.render.inputs import (
    AREA_LIGHTS,
    ENVIRONMENT,
    LIGHTS,
    MATERIALS,
    MS_TABLE,
    SHADOWS,
    SHEEN_TABLE,
    ShadingContext,
    bind_camera,
)  # fmt: skip
from app.render.lighting import LightingPass
from app.render.mesh_drawable import MeshDrawable
from app.render.texture_upload import TextureUploads
from app.scene.geometry import MeshPart

FORWARD_SHADERS = ("passes/gbuffer.vert", "passes/forward.frag")
# forward.frag as the blend pass: coverage as alpha, emission and occlusion compiled in
# (GBUFFER_EMISSION selects layers.glsl's lookups; this pass writes no G-buffer).
BLEND_DEFINES = {"ALPHA_BLEND": 1, "GBUFFER_EMISSION": 1}


# The shader inputs a blended part reads (app/render/inputs.py): the lighting pass's
# lights (as the texture), material table, lookup tables, environment light and shadow
# maps; not the G-buffer (it writes none) nor the tiles (it loops over every light).
BLEND_INPUTS = (LIGHTS, MATERIALS, MS_TABLE, SHEEN_TABLE, ENVIRONMENT, SHADOWS, AREA_LIGHTS)


def blend_defines(context: ShadingContext) -> dict[str, int]:
    """``BLEND_DEFINES`` plus the defines of the frame's inputs the pass reads
    (``BLEND_INPUTS``: the image-based light and the shadow maps have some), so that a
    blended part is lit as an opaque one (glsl/lights/shading.glsl)."""
    return {**BLEND_DEFINES, **context.only(*BLEND_INPUTS).defines()}


def blended(part: MeshPart) -> bool:
    """Whether the part is drawn by the blend pass: glTF alphaMode BLEND on its (first)
    layer, the one whose coverage glTF defines."""
    return part.layers[0].alpha_mode == "blend"


def forward_drawables(
    ctx: moderngl.Context,
    shaders: ShaderCache,
    parts: list[MeshPart],
    material_ids: list[list[int]],
    table: MaterialTable,
    terms: str,
    specular_aa: tuple[float, float] | None,
    defines: dict[str, int] | None = None,
    uploads: TextureUploads | None = None,
) -> list[MeshDrawable]:
    """The drawables of glsl/passes/forward.frag for ``parts`` (the bench's forward
    renderer and the blend pass): a part is drawn once per model group among its layers,
    each draw keeping the fragments whose dominant layer is of its group (MODEL_GROUP), as
    the lighting pass shades such a part with one permutation per group. ``defines``: the
    caller's own (ALPHA_BLEND); GBUFFER_COAT_NORMAL selects the coats' own normals as the
    deferred pass has them (the forward pass has no G-buffer). ``uploads``: the GL
    textures of the parts' maps, shared (their owner releases them); None: each drawable
    uploads its own."""
    common = {
        "BRDF_TERMS": BRDF_TERMS[terms],
        "GBUFFER_COAT_NORMAL": int(table.needs_coat_normals),
        **table.factor_defines(),  # the extension maps' factors, sampled per fragment
        **(defines or {}),
    }
    group_defines = [{**model.defines(), **common} for model in table.models]
    drawables = []
    for part, rows in zip(parts, material_ids, strict=True):
        groups = sorted({table.groups[row] for row in rows})
        for group in groups:
            part_defines = dict(group_defines[group])
            if len(groups) > 1:
                part_defines["MODEL_GROUP"] = group
            drawables.append(
                MeshDrawable(
                    ctx, shaders, part, rows, FORWARD_SHADERS, part_defines, specular_aa, uploads
                )
            )
    return drawables


def world_centre(part: MeshPart) -> np.ndarray:
    """The world position of the centre of the part's object-space bounding box: the
    point whose view depth is the key of the back-to-front sort."""
    positions = np.asarray(part.vertices, np.float64).reshape(-1, 12)[:, :3]
    centre = 0.5 * (positions.min(axis=0) + positions.max(axis=0))
    return part.model @ np.append(centre, 1.0)


def draw_farthest_first(
    ctx: moderngl.Context,
    context: ShadingContext,
    drawables: list[MeshDrawable],
    centres: list[np.ndarray],
    view: np.ndarray,
    proj: np.ndarray,
    camera: CameraFrame,
    size: tuple[int, int],
    first_map: int,
    uniforms: dict[str, object] | None = None,
) -> None:
    """Draw a forward pass's parts (``drawables``, whose world bounding-box centres are
    ``centres``) farthest first, into the bound target with the GL state the pass set:
    each with its transform, camera and material (its maps from unit ``first_map`` on) and
    the shader inputs of ``context``, ``u_image_size`` and ``uniforms`` where its program
    has them. A closed part draws its front faces; an open (two-sided) part its back faces,
    then its front faces. The sort is by the view depth of each centre, stable, so parts
    at one depth keep scene order (what this approximates: the module docstring)."""
    view_bytes, proj_bytes = gl_bytes(view), gl_bytes(proj)
    image_size = tuple(float(x) for x in size)
    depths = [-float((view @ c)[2]) for c in centres]  # metres along the view axis
    order = sorted(range(len(depths)), key=lambda k: -depths[k])
    for d in (drawables[k] for k in order):
        prog = d.program
        d.bind_transform(view_bytes, proj_bytes)
        d.bind_camera(camera, size)
        bind_camera(prog, camera)
        d.bind_material(first_unit=first_map)
        if "u_image_size" in prog:  # the compiler drops what a permutation does not use
            prog["u_image_size"].value = image_size
        for name, value in (uniforms or {}).items():
            if name in prog:
                prog[name].value = value
        context.bind(prog)
        d.cull(ctx)
        if d.part.closed:
            d.vao.render(moderngl.TRIANGLES)
            continue
        ctx.enable(moderngl.CULL_FACE)  # two-sided: the far side first, then the near
        for face in ("front", "back"):
            ctx.cull_face = face
            d.vao.render(moderngl.TRIANGLES)


class OverOpaqueTarget:
    """The framebuffer a forward pass draws into over the opaque image: the lighting
    pass's HDR image with the G-buffer's depth buffer (z-tested, not written), made again
    when either is new (a resize or a new lighting pass). The blend and the transmission
    pass each keep one."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.fbo: moderngl.Framebuffer | None = None
        self._attached: tuple[moderngl.Texture, moderngl.Renderbuffer] | None = None

    def attach(self, hdr: moderngl.Texture, zbuffer: moderngl.Renderbuffer) -> bool:
        """Make ``fbo`` of ``hdr`` and ``zbuffer`` where it holds others (or none yet);
        whether it did (what the pass keeps beside it is then stale too)."""
        attached = self._attached
        if attached is not None and attached[0] is hdr and attached[1] is zbuffer:
            return False
        self.release()
        self.fbo = self.ctx.framebuffer([hdr], zbuffer)
        self._attached = (hdr, zbuffer)
        return True

    def framebuffer(
        self, hdr: moderngl.Texture, zbuffer: moderngl.Renderbuffer
    ) -> moderngl.Framebuffer:
        """``fbo``, attached to ``hdr`` and ``zbuffer`` (``attach``)."""
        self.attach(hdr, zbuffer)
        assert self.fbo is not None
        return self.fbo

    def release(self) -> None:
        release_objects(self.fbo)
        self.fbo = None
        self._attached = None


class BlendPass:
    """The blended parts of a frame, composited over the lighting pass's HDR image."""

    def __init__(
        self, ctx: moderngl.Context, drawables: list[MeshDrawable], context: ShadingContext
    ) -> None:
        """``drawables``: ``forward_drawables`` of the blended parts only, compiled with
        ``blend_defines(context)`` and the lighting pass's material table and terms.
        ``context``: the frame's shader inputs (the lighting pass's), of which the pass
        binds ``BLEND_INPUTS``."""
        context.require("the blend pass", LIGHTS, MATERIALS)
        self.ctx = ctx
        self.context = context.only(*BLEND_INPUTS)
        self.drawables = drawables
        self._centres = [world_centre(d.part) for d in drawables]  # once: parts do not move
        self._target = OverOpaqueTarget(ctx)

    def run(
        self,
        gbuffer: GBuffer,
        lighting: LightingPass,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """Composite every blended part, farthest first, over ``lighting.hdr``; the shader
        inputs (lights, material table, lookup tables, environment, shadow maps) are the
        context's, the lighting pass's."""
        ctx = self.ctx
        fbo = self._target.framebuffer(lighting.hdr, gbuffer.zbuffer)
        fbo.use()
        size = lighting.size
        ctx.viewport = (0, 0, *size)
        ctx.enable_only(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.depth_func = "<"
        fbo.depth_mask = False  # tested against the opaque surfaces, never written
        # RGB "over"; alpha (coverage: 1 on opaque surfaces, 0 on a transparent background)
        # "over" too, a_src + (1 - a_src) a_dst, so the target stays premultiplied RGBA.
        over = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_func = (*over, moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_equation = moderngl.FUNC_ADD
        first_map = self.context.use()  # the layers' maps on the units after the inputs'
        draw_farthest_first(
            ctx, self.context, self.drawables, self._centres, view, proj, camera, size, first_map
        )
        fbo.depth_mask = True
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        self._target.release()
