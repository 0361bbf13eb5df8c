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

Everything the pass reads (G-buffer, lights, material table, lookup tables, tile masks,
environment light, shadow maps) is a shader input of the frame's ``ShadingContext``
(app/render/inputs.py): the programs compile with the context's defines and every draw
binds through it, so a new input reaches the pass without an edit here.

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
from app.common.models import BRDF_TERMS
from app.common.tonemaps import TONEMAP_CODE
from app.gl.context import release_objects
from app.gl.fullscreen import FULLSCREEN_VERTEX, FullscreenDraw
from app.gl.shaders import ShaderCache, ShaderError
from app.render.fullscreen import read_rgb
from app.render.gbuffer import GBuffer
from app.render.inputs import (
    ENVIRONMENT,
    GBUFFER,
    LIGHTS,
    MATERIALS,
    MS_TABLE,
    SHADOWS,
    SHEEN_TABLE,
    TILES,
    LightInput,
    ShaderInput,
    ShadingContext,
    bind_camera,
)  # fmt: skip

LIGHT_FORMS = ("texture", "uniform")
# Fragment uniform vectors left to everything but the lights (camera, IBL, counts) and,
# per shadow map, to its matrix and parameters (glsl/lights/shadows.glsl: 8 vectors, and
# 2 per shadowed light, which has at least one map).
_OTHER_VECTORS = 64
_VECTORS_PER_SHADOW_MAP = 10
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


def _draws(
    ctx: moderngl.Context,
    shaders: ShaderCache,
    variants: list[dict[str, int]],
    lights: LightInput,
) -> list[FullscreenDraw]:
    """The lighting programs' full-screen draws of ``variants`` (their defines), reading
    the lights as ``lights`` gives them (its ``LIGHT_UNIFORMS`` for "uniform")."""
    extra = lights.defines()
    programs = [  # every one compiled before a vertex array is made (the form's fallback)
        shaders.program(FULLSCREEN_VERTEX, "passes/lighting.frag", {**defines, **extra})
        for defines in variants
    ]
    return [FullscreenDraw(ctx, program) for program in programs]


class LightingPass:
    """Owns the HDR target; shades through a ``ShadingContext`` (app/render/inputs.py)."""

    # What no lighting program shades without; the culler, the environment's light and
    # the shadow maps are compiled in where the context has them.
    NEEDS = (GBUFFER, LIGHTS, MATERIALS)

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        context: ShadingContext,
        terms: str = "all",
        uber: bool = False,
        *,
        form: str | None = None,
    ) -> None:
        """``context``: the frame's shader inputs (``shading_context``): the G-buffer (its
        defines: encoding and layout, which the decode follows), the lights, the material
        table and its lookup tables, and where the frame has them the tile culler, the
        environment's light (ENVIRONMENT_IBL's split sum or ENVIRONMENT_UNIFORM's
        quadrature, docs/ibl.md) and the shadow maps (``SHADOWS``,
        glsl/lights/shadows.glsl); the pass releases it with itself (the inputs it made:
        not the G-buffer, culler, environment or shadow maps, which are the renderer's).
        ``terms``: the scene's render.terms, which reflections the BRDF returns.
        ``uber``: one program with run-time model selection instead of one per model
        group (the bench's, from ``RenderOptions``; the context then has every lookup
        table). ``form``: where the pass reads its lights, one of ``LIGHT_FORMS``; None
        chooses (``light_form``), the bench forces one to compare them."""
        context.require("the lighting pass", *self.NEEDS)
        self.ctx = ctx
        self.inputs = context
        self.uber = uber
        table = context[MATERIALS].table
        lights = context[LIGHTS]
        shadow_maps = context[SHADOWS].count if SHADOWS in context else 0
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
            form = light_form(ctx, lights.count, shadow_maps)
        if form not in LIGHT_FORMS:
            raise ValueError(f"unknown light form {form!r}; choose from {LIGHT_FORMS}")
        # the context's defines (G-buffer, culler, environment, shadows) and the pass's
        frame = context.defines()
        for defines in variants:
            defines.update(frame)
            defines["BRDF_TERMS"] = BRDF_TERMS[terms]
            defines["FAR_PLANE"] = 1  # the triangle the z-test culls to surfaces (run)
        slots = uniform_slots(ctx, lights.count, shadow_maps)
        try:
            shaded = lights.in_form(form, slots)
            self.draws = _draws(ctx, shaders, variants, shaded)
        except ShaderError:
            if not (chosen and form == "uniform"):
                raise
            # A driver whose other uniforms take more room than _OTHER_VECTORS allows
            # for: the light texture, which has no such limit.
            form = "texture"
            shaded = lights.in_form(form, slots)
            self.draws = _draws(ctx, shaders, variants, shaded)
        self.form = form
        # the inputs the programs read, the lights in their form
        self.context = context.with_inputs(shaded)
        self.programs = [draw.program for draw in self.draws]
        self._variants = variants
        # run_display's draws, per tone map, compiled at first use
        self._display: dict[tuple[str, bool], list[FullscreenDraw]] = {}
        self.hdr = ctx.texture(size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self._z_fbo: moderngl.Framebuffer | None = None  # hdr + the G-buffer's z (run)
        self._z_source: GBuffer | None = None
        self._shaders = shaders
        # run's background: the far-plane triangle where the G-buffer has no surface
        self._background = FullscreenDraw.of(
            ctx, shaders, "passes/hdr_background.frag", {"FAR_PLANE": 1}
        )
        self.size = size

    # The inputs as attributes, for the passes and tests that read them.
    @property
    def lights(self) -> moderngl.Texture:
        """The light texture (3 texels per light, one light per row)."""
        return self.inputs[LIGHTS].texture

    @property
    def light_count(self) -> int:
        return self.inputs[LIGHTS].count

    @property
    def materials(self) -> moderngl.Texture:
        """The material table's texture."""
        return self.inputs[MATERIALS].texture

    @property
    def ms_table(self) -> moderngl.Texture | None:
        """The Kulla-Conty table's texture, where a model (or the uber program) reads it."""
        table = self.inputs.get(MS_TABLE)
        return table.texture if table is not None else None

    @property
    def sheen_table(self) -> moderngl.Texture | None:
        """The sheen albedo table's texture (RTR4 §9.10), where a model reads it."""
        table = self.inputs.get(SHEEN_TABLE)
        return table.texture if table is not None else None

    @property
    def culler(self) -> ShaderInput | None:
        return self.inputs.get(TILES)

    @property
    def ibl(self) -> ShaderInput | None:
        return self.inputs.get(ENVIRONMENT)

    @property
    def shadows(self) -> ShaderInput | None:
        return self.inputs.get(SHADOWS)

    def run(self, gbuffer: GBuffer, camera: CameraFrame, background: np.ndarray) -> None:
        """The HDR image: ``background`` where ``gbuffer`` has no surface, the radiance of
        every surface pixel elsewhere (alpha 1). ``background``: RGB (alpha 1), or RGBA:
        (0, 0, 0, 0) for a transparent background (docs/architecture.md, "Alpha")."""
        value = tuple(float(x) for x in background)
        if len(value) == 3:
            value += (1.0,)
        target = self._z_target(gbuffer)
        for draw in self.draws:  # a surface whose depth decodes as none
            draw.program["u_background"].value = value
        self._shade(self.draws, target, camera)
        # The pixels without a surface, which the draws above skip (their z is the
        # cleared 1): the whole target is not cleared first (docs/performance.md,
        # "Fixed costs", measures it).
        self._background.draw(target, {"u_background": value}, viewport=(0, 0, *self.size),
                              depth_func="<=")  # fmt: skip

    def run_display(
        self,
        gbuffer: GBuffer,
        camera: CameraFrame,
        target: moderngl.Framebuffer,
        tonemap: str,
        exposure: float,
        hdr_out: bool = False,
    ) -> None:
        """The display image of every surface pixel straight into ``target``: the post
        pass's RGBA8 image with ``gbuffer``'s z-buffer attached, its other pixels already
        the background's display value (PostPass.display_target). The same radiance as
        ``run``'s in float32, then passes/post.frag's arithmetic with ``tonemap`` and the
        linear ``exposure`` (DISPLAY_OUT in passes/lighting.frag), so the bytes are the
        post pass's; the HDR image is not written, unless ``hdr_out``: then ``target``'s
        second attachment takes the surface pixels' radiance (HDR_OUT; its background
        pixels are left as they were)."""
        draws = self.display_draws(tonemap, hdr_out)
        for draw in draws:
            draw.program["u_exposure"].value = exposure
        self._shade(draws, target, camera)

    def run_surfaces(self, gbuffer: GBuffer, camera: CameraFrame) -> None:
        """The radiance of ``gbuffer``'s surface pixels alone into the HDR image (its
        other pixels left as they were): for a frame whose display image another pass
        writes at every surface pixel (gbaa's interior correction, Renderer.run_lighting),
        where the display image's tone map here would be drawn over."""
        self._shade(self.draws, self._z_target(gbuffer), camera)

    def display_draws(self, tonemap: str, hdr_out: bool = False) -> list[FullscreenDraw]:
        """``run_display``'s draws for ``tonemap`` (DISPLAY_OUT, and HDR_OUT where
        ``hdr_out``), compiled at their first use: a renderer that never draws a plain
        frame never compiles them (tests/test_glsl_strict.py builds them without drawing)."""
        key = (tonemap, hdr_out)
        if key not in self._display:
            out = {"HDR_OUT": 1} if hdr_out else {}
            defines = [{**d, "DISPLAY_OUT": 1, "TONEMAP": TONEMAP_CODE[tonemap], **out}
                       for d in self._variants]  # fmt: skip
            self._display[key] = _draws(self.ctx, self._shaders, defines, self.context[LIGHTS])
        return self._display[key]

    def _shade(
        self, draws: list[FullscreenDraw], target: moderngl.Framebuffer, camera: CameraFrame
    ) -> None:
        """Draw ``draws`` (one per model group) into ``target``, which has the G-buffer's
        z-buffer attached with depth writes off."""
        # The full-screen triangle lies on the far plane and is tested against the
        # G-buffer's z-buffer with ">" (never written): where no surface was drawn z is
        # still the cleared 1 and llvmpipe skips the fragment shader before it runs, block
        # by block, where the shader would fetch RT2 and discard. Every pixel the test
        # passes has a drawn surface, which decode_gbuffer still checks, so the image is
        # the same (docs/performance.md, "Fixed costs", measures the gain).
        self.context.use()
        for draw in draws:
            self.context.bind(draw.program)
            bind_camera(draw.program, camera)
            draw.draw(target, viewport=(0, 0, *self.size), depth_func=">")

    def _z_target(self, gbuffer: GBuffer) -> moderngl.Framebuffer:
        """The HDR image with ``gbuffer``'s z-buffer, depth writes off; made again for a new
        G-buffer (a resize, a new encoding)."""
        if self._z_fbo is None or self._z_source is not gbuffer:
            release_objects(self._z_fbo)
            self._z_fbo = self.ctx.framebuffer([self.hdr], gbuffer.zbuffer)
            self._z_fbo.depth_mask = False
            self._z_source = gbuffer
        return self._z_fbo

    def read(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        release_objects(*self.draws, self._background, self.fbo, self.hdr, self._z_fbo)
        for draws in self._display.values():  # the programs are the shader cache's
            for draw in draws:
                draw.release()
        self.inputs.release()  # the textures the frame's context made
