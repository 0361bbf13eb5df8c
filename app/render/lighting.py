"""The lighting pass: the illumination sum over the G-buffer, into linear HDR.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (RTR4 §9.4, eq. 9.13), evaluated by
glsl/passes/lighting.frag into an RGBA32F target. Lights travel in an RGBA32F texture
(3 texels per light, one light per row), so their number is bounded only by the
texture height, not by uniform-block limits.

One program per model group (app/frame/materials.py): a scene whose materials all use
one model runs one full-screen pass; otherwise each group's pass discards the pixels of
the other groups, so no pixel pays for a branch of a model it does not use. The bench's
``uber`` option (``RenderOptions``, the ``specialization`` suite) builds the opposite for
comparison: one program for every material, each model a run-time branch on codes from
the material table (UBER_MODELS in glsl/brdf/model.glsl), paying for every model and table.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import encoding_defines
from app.common.lights import PunctualLight, pack_lights
from app.common.models import BRDF_TERMS
from app.frame.camera import gl_bytes
from app.frame.materials import MaterialTable
from app.gl.shaders import ShaderCache
from app.render.culling import TILE_SIZE, LightCuller
from app.render.gbuffer import GBuffer
from app.render.ibl import EnvironmentLighting, UniformEnvironment
from app.render.post import read_rgb
from app.render.shadows import ShadowPass
from app.render.tables import material_texture, ms_texture, sheen_texture


class LightingPass:
    """Owns the HDR target and the light texture."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        lights: list[PunctualLight],
        table: MaterialTable,
        culler: LightCuller | None = None,
        terms: str = "all",
        uber: bool = False,
        ms_table: np.ndarray | None = None,
        *,
        encoding: str,
        ibl: EnvironmentLighting | UniformEnvironment | None = None,
        shadows: ShadowPass | None = None,
    ) -> None:
        """``encoding``: the G-buffer's render.gbuffer (its decode, gbuffer/layout.glsl).
        ``terms``: the scene's render.terms, which reflections the BRDF returns.
        ``uber``: one program with run-time model selection instead of one per model
        group, and ``ms_table``: a Kulla-Conty table other than the shipped default (both
        the bench's, from ``RenderOptions``). ``shadows``: the shadow maps, where a light
        casts shadows (compiled in as ``SHADOWS``, glsl/lights/shadows.glsl). ``ibl``: the
        environment's light (ENVIRONMENT_IBL's split sum or ENVIRONMENT_UNIFORM's
        quadrature, docs/ibl.md), None without an environment."""
        self.ctx = ctx
        self.culler = culler
        self.shadows = shadows
        self.uber = uber
        several = len(table.models) > 1
        variants: list[dict[str, int]] = []
        if uber:
            variants.append({"UBER_MODELS": 1})
        for group, model in enumerate(table.models if not uber else ()):
            defines = dict(model.defines())
            if several:
                defines["MODEL_GROUP"] = group
            variants.append(defines)
        self.programs = []
        for defines in variants:
            defines.update(table.gbuffer_defines())
            defines.update(encoding_defines(encoding))
            defines["BRDF_TERMS"] = BRDF_TERMS[terms]
            if ibl is not None:  # an environment (docs/ibl.md)
                defines.update(ibl.defines())
            if shadows is not None:
                defines.update(shadows.defines())
            if culler is not None:
                defines["TILED_LIGHTS"] = 1
                defines["TILE_SIZE"] = TILE_SIZE  # the culler's tiles
                defines["TILE_QUADS"] = culler.quads  # mask texels per tile
                defines["DIRECTIONAL_LIGHTS"] = int(culler.first_local > 0)
            defines["FAR_PLANE"] = 1  # the triangle the z-test culls to surfaces (run)
            self.programs.append(
                shaders.program("passes/fullscreen.vert", "passes/lighting.frag", defines)
            )
        self.vaos = [ctx.vertex_array(prog, []) for prog in self.programs]
        self.materials = material_texture(ctx, table)
        self.ms_table = None
        if uber or any(model.multiscatter for model in table.models):
            self.ms_table = ms_texture(ctx, ms_table)
        self.sheen_table = None  # sheen (RTR4 §9.10): the albedo table, where a model uses it
        if uber or any(model.sheen != "none" for model in table.models):
            self.sheen_table = sheen_texture(ctx)
        self.hdr = ctx.texture(size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self._z_fbo: moderngl.Framebuffer | None = None  # hdr + the G-buffer's z (run)
        self._z_source: GBuffer | None = None
        packed = pack_lights(lights)
        self.lights = ctx.texture((3, packed.shape[0]), 4, packed.tobytes(), dtype="f4")
        self.lights.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.light_count = len(lights)
        self.size = size
        self.ibl = ibl  # owned by the renderer

    def run(
        self,
        gbuffer: GBuffer,
        camera: CameraFrame,
        background: np.ndarray,
    ) -> None:
        ctx = self.ctx
        self.fbo.use()
        ctx.viewport = (0, 0, *self.size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self.fbo.clear(*(float(x) for x in background), 1.0)  # pixels no surface covers
        # The full-screen triangle lies on the far plane and is tested against the
        # G-buffer's z-buffer with ">" (never written): where no surface was drawn z is
        # still the cleared 1 and llvmpipe skips the fragment shader before it runs, block
        # by block, where the shader would fetch RT2 and discard. Every pixel the test
        # passes has a drawn surface, which decode_gbuffer still checks, so the image is
        # the same (docs/performance.md, "Second part: fixed costs", measures the gain).
        self._z_target(gbuffer).use()
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"
        textures = [
            *gbuffer.samplers(),
            ("u_lights", self.lights),
            ("u_materials", self.materials),
        ]
        if self.ms_table is not None:
            textures.append(("u_ms_table", self.ms_table))
        if self.sheen_table is not None:
            textures.append(("u_sheen_table", self.sheen_table))
        if self.culler is not None:
            textures.append(("u_tile_masks", self.culler.masks))
        if self.ibl is not None:
            textures.extend(self.ibl.samplers())
        if self.shadows is not None:
            textures.append(("u_shadow_atlas", self.shadows.atlas))
        for unit, (_, tex) in enumerate(textures):
            tex.use(unit)
        camera_to_world = gl_bytes(camera.camera_to_world)
        for prog, vao in zip(self.programs, self.vaos, strict=True):
            for unit, (name, _) in enumerate(textures):
                if name in prog:  # a permutation may not use every texture
                    prog[name].value = unit
            if "u_light_count" in prog:  # the tiled loop counts through its masks instead
                prog["u_light_count"].value = self.light_count
            prog["u_camera_pos"].value = tuple(float(x) for x in camera.position)
            prog["u_camera_to_world"].write(camera_to_world)
            prog["u_tan_half_fov"].value = camera.tan_half_fov
            if self.culler is not None:
                prog["u_first_local"].value = self.culler.first_local
            if self.ibl is not None:
                self.ibl.set_uniforms(prog)
            if self.shadows is not None:
                self.shadows.bind(prog)
            vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"

    def _z_target(self, gbuffer: GBuffer) -> moderngl.Framebuffer:
        """The HDR image with ``gbuffer``'s z-buffer, depth writes off; made again for a new
        G-buffer (a resize, a new encoding)."""
        if self._z_fbo is None or self._z_source is not gbuffer:
            if self._z_fbo is not None:
                self._z_fbo.release()
            self._z_fbo = self.ctx.framebuffer([self.hdr], gbuffer.zbuffer)
            self._z_fbo.depth_mask = False
            self._z_source = gbuffer
        return self._z_fbo

    def read(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        for obj in (*self.vaos, self.fbo, self.hdr, self.lights, self.materials):
            obj.release()
        if self._z_fbo is not None:
            self._z_fbo.release()
        if self.ms_table is not None:
            self.ms_table.release()
        if self.sheen_table is not None:
            self.sheen_table.release()
