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
from app.render.post import read_rgb
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
        texels = -(-self.count // PER_TEXEL)
        packed = np.concatenate([pack_lights(renderer.lights)[: len(renderer.lights)],
                                 dark_light()[None]])  # fmt: skip
        dark = len(packed) - 1
        room = {"uniform": ctx.info["GL_MAX_FRAGMENT_UNIFORM_VECTORS"],
                "ubo": ctx.info["GL_MAX_UNIFORM_BLOCK_SIZE"] // 16}.get(form)  # fmt: skip
        if room is not None and 3 * len(packed) > room:
            raise ValueError(f"{len(packed)} lights need {3 * len(packed)} vec4 in a {form},"
                             f" the context allows {room}: use form 'texture'")  # fmt: skip
        # The dark light is a point light; without directional lights the limit takes
        # the culled pass's local term (local_light_term, lights/illumination.glsl).
        local_only = int(all(x.is_local for x in renderer.lights))
        table = renderer.materials
        several = len(table.models) > 1
        self.programs = []
        for group, model in enumerate(table.models):
            defines: dict[str, object] = dict(model.defines())
            defines.update(renderer.gbuffer.defines())
            defines["BRDF_TERMS"] = BRDF_TERMS[renderer.scene.render.terms]
            defines.update(LIMIT_FORM=FORMS.index(form), LIMIT_LIGHTS=len(packed),
                           LIMIT_COUNT=self.count, LIMIT_TEXELS=texels,
                           LIMIT_LOCAL_ONLY=local_only, FAR_PLANE=1)  # fmt: skip
            if several:
                defines["MODEL_GROUP"] = group
            self.programs.append(
                renderer.shaders.program("passes/fullscreen.vert", "passes/limit.frag", defines)
            )
        self.vaos = [ctx.vertex_array(prog, []) for prog in self.programs]
        w, h = self.size
        indices = np.zeros((h, w, texels * PER_TEXEL), np.uint16)
        indices[..., : self.count] = pixel_light_indices(pairs, self.count, dark)
        words = np.ascontiguousarray(indices[::-1]).view(np.uint32)  # GL rows bottom-up
        self.indices = ctx.texture((w * texels, h), 4, words.tobytes(), dtype="u4")
        self.indices.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.lights: moderngl.Texture | None = None
        self.block: moderngl.Buffer | None = None
        self.light_bytes = np.ascontiguousarray(packed).tobytes()
        if form == "texture":
            self.lights = ctx.texture((3, len(packed)), 4, self.light_bytes, dtype="f4")
            self.lights.filter = (moderngl.NEAREST, moderngl.NEAREST)
        elif form == "ubo":
            self.block = ctx.buffer(self.light_bytes)
        self.hdr = ctx.texture(self.size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self.z_fbo = z_target(renderer, self.hdr)

    def run(self) -> None:
        """Shade the renderer's current G-buffer (its G-buffer pass must have run)."""
        textures = [("u_pixel_lights", self.indices)]
        if self.lights is not None:
            textures.append(("u_lights", self.lights))
        if self.block is not None:
            self.block.bind_to_uniform_block(_BLOCK_BINDING)
        shade_gbuffer(self.renderer, self.fbo, self.z_fbo, self.programs, self.vaos, textures,
                      self._light_uniforms)  # fmt: skip

    def _light_uniforms(self, prog: moderngl.Program) -> None:
        if self.form == "uniform":
            prog["u_light_vec"].write(self.light_bytes)
        elif self.form == "ubo":
            prog["LimitLights"].binding = _BLOCK_BINDING

    def read_hdr(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        for obj in (
            *self.vaos,
            self.z_fbo,
            self.fbo,
            self.hdr,
            self.indices,
            self.lights,
            self.block,
        ):
            if obj is not None:
                obj.release()
