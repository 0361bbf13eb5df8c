"""The limit pass: the machine's own bound on the lighting pass (the bench's ``limit``).

The ``floor`` variant (app/bench/floor.py) walks exact per-pixel light masks with the
lighting pass's own loop, so it pays for the same list walk and light fetches as the
culled pass and hides how far both are from what the machine can do. The limit pass
(glsl/passes/limit.frag) keeps only what no pipeline can drop: the G-buffer decode and
the default model's term (``light_term``, glsl/lights/illumination.glsl) for ``count``
lights per pixel, in a loop of compile-time length, over the pixel's own lights in
ascending order. Their indices were found exactly on the CPU (app/bench/pairs.py) and
are uploaded untimed, 16 bits each, 8 per RGBA32UI texel. ``count`` is the measured mean
of lights per covered pixel, rounded: a pixel with fewer repeats a dark light placed out
of every pixel's range, a pixel with more keeps its first ``count``. So the limit pays
``count`` terms at every covered pixel (``terms`` in its row), about the pairs' total,
and its image is the scene's only where a pixel has at most ``count`` lights.

Where the light parameters live is the ``form``: the light texture (``texture``, as the
lighting pass), a uniform array (``uniform``) or a uniform block (``ubo``). The bench's
``limit`` variant uses ``LIMIT_FORM``, the fastest of the three here
(docs/performance.md has the measurement).
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.bench.floor import shade_gbuffer, z_target
from app.bench.pairs import LightPairs
from app.common.lights import pack_lights
from app.common.models import BRDF_TERMS
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw
from app.render.fullscreen import read_rgb
from app.render.inputs import GBUFFER, MATERIALS, MS_TABLE, SHEEN_TABLE, ShaderInput
from app.render.renderer import Renderer

FORMS = ("texture", "uniform", "ubo")
LIMIT_FORM = "uniform"  # the fastest form on this machine (docs/performance.md)
PER_TEXEL = 8  # 16-bit light indices per RGBA32UI texel
_BLOCK_BINDING = 0


def dark_light() -> np.ndarray:
    """(3, 4) float32 texels of a point light that adds exactly 0 everywhere: no colour,
    1 m range, a million metres from any surface."""
    return np.array([[1e6, 1e6, 1e6, 1.0], [0.0, 0.0, -1.0, 1.0], [0.0, 0.0, 0.0, -2.0]],
                    np.float32)  # fmt: skip


def pixel_light_indices(pairs: LightPairs, count: int, dark: int) -> np.ndarray:
    """(H, W, count) uint16, rows top to bottom: each pixel's first ``count`` lights in
    ascending order, then ``dark`` for the slots it has no light for."""
    h, w = pairs.count.shape
    out = np.full((h * w, count), dark, np.uint16)
    pixel = pairs.pixel_index()
    rank = np.arange(pixel.size, dtype=np.int64) - pairs.first.ravel().astype(np.int64)[pixel]
    keep = rank < count
    out[pixel[keep], rank[keep]] = pairs.lights[keep]
    return out.reshape(h, w, count)


class LimitLights(ShaderInput):
    """The limit pass's lights (the frame's, then ``dark_light``) in ``form``: the texture
    ``u_lights``, the uniform array ``u_light_vec`` or the uniform block ``LimitLights``
    (``LIMIT_FORM``, ``LIMIT_LIGHTS``)."""

    role = "limit_lights"

    def __init__(self, ctx: moderngl.Context, packed: np.ndarray, form: str) -> None:
        self.form, self.count = form, len(packed)
        self.texels = np.ascontiguousarray(packed).tobytes()
        self.texture: moderngl.Texture | None = None
        self.block: moderngl.Buffer | None = None
        if form == "texture":
            self.texture = ctx.texture((3, len(packed)), 4, self.texels, dtype="f4")
            self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        elif form == "ubo":
            self.block = ctx.buffer(self.texels)

    def defines(self) -> dict[str, int]:
        return {"LIMIT_FORM": FORMS.index(self.form), "LIMIT_LIGHTS": self.count}

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        return [("u_lights", self.texture)] if self.texture is not None else []

    def uniforms(self, program: moderngl.Program) -> None:
        if self.form == "uniform":
            program["u_light_vec"].write(self.texels)
        elif self.block is not None:
            self.block.bind_to_uniform_block(_BLOCK_BINDING)
            program["LimitLights"].binding = _BLOCK_BINDING

    def release(self) -> None:
        for obj in (self.texture, self.block):
            if obj is not None:
                obj.release()


class PixelLights(ShaderInput):
    """The limit pass's per-pixel light indices (``pixel_light_indices``), 16 bits each,
    ``PER_TEXEL`` to an RGBA32UI texel of ``u_pixel_lights`` (``LIMIT_COUNT`` of them,
    ``LIMIT_TEXELS`` texels a pixel)."""

    role = "pixel_lights"

    def __init__(self, ctx: moderngl.Context, pairs: LightPairs, count: int, dark: int) -> None:
        self.count = count
        self.texels = -(-count // PER_TEXEL)
        h, w = pairs.count.shape
        indices = np.zeros((h, w, self.texels * PER_TEXEL), np.uint16)
        indices[..., :count] = pixel_light_indices(pairs, count, dark)
        words = np.ascontiguousarray(indices[::-1]).view(np.uint32)  # GL rows bottom-up
        self.texture = ctx.texture((w * self.texels, h), 4, words.tobytes(), dtype="u4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def defines(self) -> dict[str, int]:
        return {"LIMIT_COUNT": self.count, "LIMIT_TEXELS": self.texels}

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        return [("u_pixel_lights", self.texture)]

    def release(self) -> None:
        self.texture.release()


class LimitPass:
    """Shades a ``Renderer``'s G-buffer with ``count`` lights per pixel into its own HDR
    target, the lights' parameters in ``form`` (one of ``FORMS``)."""

    def __init__(self, renderer: Renderer, pairs: LightPairs, form: str = LIMIT_FORM) -> None:
        if form not in FORMS:
            raise ValueError(f"unknown light form {form!r}; choose from {FORMS}")
        if len(renderer.lights) >= 0xFFFF:
            raise ValueError("the limit pass indexes lights with 16 bits")
        ctx = renderer.gl.ctx
        self.ctx, self.renderer, self.size, self.form = ctx, renderer, renderer.size, form
        self.count = max(1, round(pairs.mean_per_covered_pixel))
        self.terms = self.count * int(pairs.covered.sum())
        packed = np.concatenate([pack_lights(renderer.lights)[: len(renderer.lights)],
                                 dark_light()[None]])  # fmt: skip
        dark = len(packed) - 1
        room = {"uniform": ctx.info["GL_MAX_FRAGMENT_UNIFORM_VECTORS"],
                "ubo": ctx.info["GL_MAX_UNIFORM_BLOCK_SIZE"] // 16}.get(form)  # fmt: skip
        if room is not None and 3 * len(packed) > room:
            raise ValueError(f"{len(packed)} lights need {3 * len(packed)} vec4 in a {form},"
                             f" the context allows {room}: use form 'texture'")  # fmt: skip
        self.lights = LimitLights(ctx, packed, form)
        self.indices = PixelLights(ctx, pairs, self.count, dark)
        # the frame's G-buffer, material and lookup tables (not its lights: its own)
        frame = renderer.shading.only(GBUFFER, MATERIALS, MS_TABLE, SHEEN_TABLE)
        self.context = frame.with_inputs(self.lights, self.indices)
        # The dark light is a point light; without directional lights the limit takes
        # the culled pass's local term (local_light_term, lights/illumination.glsl).
        local_only = int(all(x.is_local for x in renderer.lights))
        table = renderer.materials
        several = len(table.models) > 1
        inputs = self.context.defines()
        self.draws = []
        for group, model in enumerate(table.models):
            defines: dict[str, object] = dict(model.defines())
            defines.update(inputs)
            defines["BRDF_TERMS"] = BRDF_TERMS[renderer.scene.render.terms]
            defines.update(LIMIT_LOCAL_ONLY=local_only, FAR_PLANE=1)
            if several:
                defines["MODEL_GROUP"] = group
            self.draws.append(
                FullscreenDraw.of(ctx, renderer.shaders, "passes/limit.frag", defines)
            )
        self.programs = [draw.program for draw in self.draws]
        self.hdr = ctx.texture(self.size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self.z_fbo = z_target(renderer, self.hdr)

    def run(self) -> None:
        """Shade the renderer's current G-buffer (its G-buffer pass must have run)."""
        shade_gbuffer(self.renderer, self.fbo, self.z_fbo, self.draws, self.context)

    def read_hdr(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        release_objects(*self.draws, self.z_fbo, self.fbo, self.hdr, self.indices, self.lights)
