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
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer
from app.render.lighting import LightingPass
from app.render.mesh_drawable import MeshDrawable
from app.scene.geometry import MeshPart

FORWARD_SHADERS = ("passes/gbuffer.vert", "passes/forward.frag")
# forward.frag as the blend pass: coverage as alpha, emission and occlusion compiled in
# (GBUFFER_EMISSION selects layers.glsl's lookups; this pass writes no G-buffer).
BLEND_DEFINES = {"ALPHA_BLEND": 1, "GBUFFER_EMISSION": 1}


def blend_defines(lighting: LightingPass) -> dict[str, int]:
    """``BLEND_DEFINES`` plus the lighting pass's image-based light and shadow maps, so
    that a blended part is lit as an opaque one (glsl/lights/shading.glsl)."""
    defines = dict(BLEND_DEFINES)
    if lighting.ibl is not None:
        defines.update(lighting.ibl.defines())
    if lighting.shadows is not None:
        defines.update(lighting.shadows.defines())
    return defines


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
) -> list[MeshDrawable]:
    """The drawables of glsl/passes/forward.frag for ``parts`` (the bench's forward
    renderer and the blend pass): a part is drawn once per model group among its layers,
    each draw keeping the fragments whose dominant layer is of its group (MODEL_GROUP), as
    the lighting pass shades such a part with one permutation per group. ``defines``: the
    caller's own (ALPHA_BLEND); GBUFFER_COAT_NORMAL selects the coats' own normals as the
    deferred pass has them (the forward pass has no G-buffer)."""
    common = {
        "BRDF_TERMS": BRDF_TERMS[terms],
        "GBUFFER_COAT_NORMAL": int(table.needs_coat_normals),
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
                MeshDrawable(ctx, shaders, part, rows, FORWARD_SHADERS, part_defines, specular_aa)
            )
    return drawables


def world_centre(part: MeshPart) -> np.ndarray:
    """The world position of the centre of the part's object-space bounding box: the
    point whose view depth is the key of the back-to-front sort."""
    positions = np.asarray(part.vertices, np.float64).reshape(-1, 12)[:, :3]
    centre = 0.5 * (positions.min(axis=0) + positions.max(axis=0))
    return part.model @ np.append(centre, 1.0)


class BlendPass:
    """The blended parts of a frame, composited over the lighting pass's HDR image."""

    def __init__(self, ctx: moderngl.Context, drawables: list[MeshDrawable]) -> None:
        """``drawables``: ``forward_drawables`` of the blended parts only, compiled with
        ``BLEND_DEFINES`` and the lighting pass's material table and terms."""
        self.ctx = ctx
        self.drawables = drawables
        self._centres = [world_centre(d.part) for d in drawables]  # once: parts do not move
        self._fbo: moderngl.Framebuffer | None = None
        self._attached: tuple[moderngl.Texture, moderngl.Renderbuffer] | None = None

    def _target(
        self, hdr: moderngl.Texture, zbuffer: moderngl.Renderbuffer
    ) -> moderngl.Framebuffer:
        """A framebuffer of the lighting pass's HDR image and the G-buffer's depth buffer,
        made again when either is new (a resize or a new lighting pass)."""
        attached = self._attached
        if attached is None or attached[0] is not hdr or attached[1] is not zbuffer:
            if self._fbo is not None:
                self._fbo.release()
            self._fbo = self.ctx.framebuffer([hdr], zbuffer)
            self._attached = (hdr, zbuffer)
        return self._fbo

    def run(
        self,
        gbuffer: GBuffer,
        lighting: LightingPass,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """Composite every blended part, farthest first, over ``lighting.hdr``; the lights,
        material table and its lookup tables are the lighting pass's."""
        ctx = self.ctx
        fbo = self._target(lighting.hdr, gbuffer.zbuffer)
        fbo.use()
        size = lighting.size
        ctx.viewport = (0, 0, *size)
        ctx.enable_only(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.depth_func = "<"
        fbo.depth_mask = False  # tested against the opaque surfaces, never written
        # RGB "over"; the target's alpha (1 everywhere) is kept.
        over = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_func = (*over, moderngl.ZERO, moderngl.ONE)
        ctx.blend_equation = moderngl.FUNC_ADD
        view_bytes, proj_bytes = gl_bytes(view), gl_bytes(proj)
        camera_pos = tuple(float(x) for x in camera.position)
        camera_to_world = gl_bytes(camera.camera_to_world)
        units = [("u_lights", lighting.lights), ("u_materials", lighting.materials)]
        if lighting.ms_table is not None:
            units.append(("u_ms_table", lighting.ms_table))
        if lighting.sheen_table is not None:
            units.append(("u_sheen_table", lighting.sheen_table))
        if lighting.ibl is not None:  # the environment's light, as the lighting pass's
            units.extend(lighting.ibl.samplers())
        if lighting.shadows is not None:  # the lighting pass's maps (rendered before it)
            units.append(("u_shadow_atlas", lighting.shadows.atlas))
        for unit, (_, tex) in enumerate(units):
            tex.use(unit)
        # Farthest first; a stable sort keeps scene order between parts at one depth.
        depths = [-float((view @ c)[2]) for c in self._centres]  # metres along the view axis
        order = sorted(range(len(depths)), key=lambda k: -depths[k])
        for d in (self.drawables[k] for k in order):
            prog = d.program
            d.bind_transform(view_bytes, proj_bytes)
            d.bind_camera(camera, size)
            if "u_camera_to_world" in prog:
                prog["u_camera_to_world"].write(camera_to_world)
            d.bind_material(first_unit=len(units))
            values: dict[str, object] = {
                "u_light_count": lighting.light_count,
                "u_camera_pos": camera_pos,
                "u_tan_half_fov": camera.tan_half_fov,
                "u_image_size": tuple(float(x) for x in size),
                **{name: unit for unit, (name, _) in enumerate(units)},
            }
            for name, value in values.items():
                if name in prog:  # the compiler drops what a permutation does not use
                    prog[name].value = value
            if lighting.ibl is not None:
                lighting.ibl.set_uniforms(prog)
            if lighting.shadows is not None:
                lighting.shadows.bind(prog)
            d.cull(ctx)
            if d.part.closed:
                d.vao.render(moderngl.TRIANGLES)
                continue
            ctx.enable(moderngl.CULL_FACE)  # two-sided: the far side first, then the near
            for face in ("front", "back"):
                ctx.cull_face = face
                d.vao.render(moderngl.TRIANGLES)
        fbo.depth_mask = True
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        if self._fbo is not None:
            self._fbo.release()
