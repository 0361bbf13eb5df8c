"""The lighting pass: the illumination sum over the G-buffer, into linear HDR.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (RTR4 §9.4, eq. 9.13), evaluated by
glsl/passes/lighting.frag into an RGBA32F target. Lights travel in an RGBA32F texture
(3 texels per light, one light per row), so their number is bounded only by the
texture height, not by uniform limits; the blend, debug and bench passes read that
texture. The lighting pass itself reads the same texels from a uniform array
(``LIGHT_UNIFORMS``, glsl/lights/illumination.glsl) wherever they fit the context's
fragment uniform vectors: the array is the form a rasteriser such as llvmpipe reads
fastest (docs/performance.md, "The light loop"), and the texture is the
fallback for scenes with more lights. The form is chosen when the programs are built,
from the scene's light count (``light_form``).

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
from app.common.lights import PunctualLight, pack_lights
from app.common.models import BRDF_TERMS
from app.common.tonemaps import TONEMAP_CODE
from app.frame.camera import gl_bytes
from app.frame.materials import MaterialTable
from app.gl.shaders import ShaderCache, ShaderError
from app.render.culling import TILE_SIZE, LightCuller
from app.render.gbuffer import GBuffer
from app.render.ibl import EnvironmentLighting, UniformEnvironment
from app.render.post import read_rgb
from app.render.shadows import ShadowPass
from app.render.tables import material_texture, ms_texture, sheen_texture

LIGHT_FORMS = ("texture", "uniform")
# Fragment uniform vectors left to everything but the lights (camera, IBL, counts) and,
# per shadow map, to its matrix and parameters (glsl/lights/shadows.glsl: 8 vectors).
_OTHER_VECTORS = 64
_VECTORS_PER_SHADOW_MAP = 8
_MIN_UNIFORM_SLOTS = 16  # the smallest array (uniform_slots)


def light_form(ctx: moderngl.Context, light_count: int, shadow_maps: int = 0) -> str:
    """Where the lighting pass reads its lights: "uniform" when 3 vectors per light fit the
    context's GL_MAX_FRAGMENT_UNIFORM_VECTORS beside the pass's other uniforms (queried,
    never assumed: llvmpipe has 4096), else "texture"."""
    return "uniform" if 3 * max(light_count, 1) <= _room(ctx, shadow_maps) else "texture"


def _room(ctx: moderngl.Context, shadow_maps: int) -> int:
    """The fragment uniform vectors left for the lights' array."""
    room = int(ctx.info["GL_MAX_FRAGMENT_UNIFORM_VECTORS"]) - _OTHER_VECTORS
    return room - _VECTORS_PER_SHADOW_MAP * shadow_maps


def uniform_slots(ctx: moderngl.Context, light_count: int, shadow_maps: int = 0) -> int:
    """The uniform array's size in lights: ``light_count`` rounded up to a power of two of
    at least 16, within the room ``light_form`` allows (never below ``light_count``). The
    programs are cached by their defines, so a size per light count would compile the
    lighting pass again at every light added or removed (the viewer, ``OffscreenRenderer``,
    batch edits); the loops stop at the light count or the tile masks, never at the
    array's size, so the padding is never read and the image is the same."""
    count = max(light_count, 1)
    want = max(_MIN_UNIFORM_SLOTS, 1 << (count - 1).bit_length())
    return max(min(want, _room(ctx, shadow_maps) // 3), count)


def _programs(
    shaders: ShaderCache, variants: list[dict[str, int]], form: str, slots: int
) -> list[moderngl.Program]:
    """The lighting programs of ``variants`` (their defines), reading the lights in
    ``form`` (an array of ``slots`` lights for "uniform")."""
    programs = []
    for defines in variants:
        if form == "uniform":
            defines = {**defines, "LIGHT_UNIFORMS": slots}  # the array's size in lights
        programs.append(shaders.program("passes/fullscreen.vert", "passes/lighting.frag", defines))
    return programs


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
        gbuffer: dict[str, int],
        ibl: EnvironmentLighting | UniformEnvironment | None = None,
        shadows: ShadowPass | None = None,
        form: str | None = None,
    ) -> None:
        """``gbuffer``: the G-buffer's defines (``GBuffer.defines``: its encoding and
        layout, which the decode follows; gbuffer/layout.glsl).
        ``terms``: the scene's render.terms, which reflections the BRDF returns.
        ``uber``: one program with run-time model selection instead of one per model
        group, and ``ms_table``: a Kulla-Conty table other than the shipped default (both
        the bench's, from ``RenderOptions``). ``shadows``: the shadow maps, where a light
        casts shadows (compiled in as ``SHADOWS``, glsl/lights/shadows.glsl). ``ibl``: the
        environment's light (ENVIRONMENT_IBL's split sum or ENVIRONMENT_UNIFORM's
        quadrature, docs/ibl.md), None without an environment. ``form``: where the
        pass reads its lights, one of ``LIGHT_FORMS``; None chooses (``light_form``),
        the bench forces one to compare them."""
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
        chosen = form is None
        if form is None:
            form = light_form(ctx, len(lights), shadows.count if shadows is not None else 0)
        if form not in LIGHT_FORMS:
            raise ValueError(f"unknown light form {form!r}; choose from {LIGHT_FORMS}")
        for defines in variants:
            defines.update(gbuffer)
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
        slots = uniform_slots(ctx, len(lights), shadows.count if shadows is not None else 0)
        try:
            self.programs = _programs(shaders, variants, form, slots)
        except ShaderError:
            if not (chosen and form == "uniform"):
                raise
            # A driver whose other uniforms take more room than _OTHER_VECTORS allows
            # for: the light texture, which has no such limit.
            form = "texture"
            self.programs = _programs(shaders, variants, form, slots)
        self.form = form
        self.vaos = [ctx.vertex_array(prog, []) for prog in self.programs]
        self._variants, self._slots = variants, slots
        # run_display's programs and triangles, per tone map, compiled at first use
        self._display: dict[str, tuple[list[moderngl.Program], list[moderngl.VertexArray]]] = {}
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
        self._shaders = shaders
        packed = pack_lights(lights)
        texels = packed.tobytes()
        self.lights = ctx.texture((3, packed.shape[0]), 4, texels, dtype="f4")
        # LIGHT_UNIFORMS: the texture's texels, padded with zeros to the array's size
        # (moderngl writes a uniform array only whole)
        self.light_bytes = texels + bytes(48 * max(slots - packed.shape[0], 0))
        self.lights.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.light_count = len(lights)
        self.size = size
        self.ibl = ibl  # owned by the renderer

    def run(self, gbuffer: GBuffer, camera: CameraFrame, background: np.ndarray) -> None:
        """The HDR image: ``background`` where ``gbuffer`` has no surface, the radiance of
        every surface pixel elsewhere."""
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.fbo.clear(*(float(x) for x in background), 1.0)  # pixels no surface covers
        self._shade(self.programs, self.vaos, self._z_target(gbuffer), gbuffer, camera)

    def run_display(
        self,
        gbuffer: GBuffer,
        camera: CameraFrame,
        target: moderngl.Framebuffer,
        tonemap: str,
        exposure: float,
    ) -> None:
        """The display image of every surface pixel straight into ``target``: the post
        pass's RGBA8 image with ``gbuffer``'s z-buffer attached, its other pixels already
        the background's display value (PostPass.display_target). The same radiance as
        ``run``'s in float32, then passes/post.frag's arithmetic with ``tonemap`` and the
        linear ``exposure`` (DISPLAY_OUT in passes/lighting.frag), so the bytes are the
        post pass's; the HDR image is not written."""
        if tonemap not in self._display:
            defines = [{**d, "DISPLAY_OUT": 1, "TONEMAP": TONEMAP_CODE[tonemap]}
                       for d in self._variants]  # fmt: skip
            programs = _programs(self._shaders, defines, self.form, self._slots)
            self._display[tonemap] = (programs, [self.ctx.vertex_array(p, []) for p in programs])
        programs, vaos = self._display[tonemap]
        for prog in programs:
            prog["u_exposure"].value = exposure
        self._shade(programs, vaos, target, gbuffer, camera)

    def _shade(
        self,
        programs: list[moderngl.Program],
        vaos: list[moderngl.VertexArray],
        target: moderngl.Framebuffer,
        gbuffer: GBuffer,
        camera: CameraFrame,
    ) -> None:
        """Draw ``programs`` (one per model group) into ``target``, which has ``gbuffer``'s
        z-buffer attached with depth writes off."""
        ctx = self.ctx
        # The full-screen triangle lies on the far plane and is tested against the
        # G-buffer's z-buffer with ">" (never written): where no surface was drawn z is
        # still the cleared 1 and llvmpipe skips the fragment shader before it runs, block
        # by block, where the shader would fetch RT2 and discard. Every pixel the test
        # passes has a drawn surface, which decode_gbuffer still checks, so the image is
        # the same (docs/performance.md, "Fixed costs", measures the gain).
        target.use()
        ctx.viewport = (0, 0, *self.size)
        ctx.disable(moderngl.BLEND)
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
        for prog, vao in zip(programs, vaos, strict=True):
            for unit, (name, _) in enumerate(textures):
                if name in prog:  # a permutation may not use every texture
                    prog[name].value = unit
            if "u_light_vec" in prog:  # LIGHT_UNIFORMS; the program may be another scene's
                prog["u_light_vec"].write(self.light_bytes)
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
        for _, vaos in self._display.values():  # the programs are the shader cache's
            for vao in vaos:
                vao.release()
        if self.ms_table is not None:
            self.ms_table.release()
        if self.sheen_table is not None:
            self.sheen_table.release()
