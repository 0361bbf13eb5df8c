"""The floor pass: what no lighting pipeline can go under (the bench's ``floor`` variant).

A bare full-screen pass (glsl/passes/floor.frag) that decodes the G-buffer and evaluates
the lighting pass's light term exactly once per (pixel, light in range) pair (under
``FLOOR_LOCAL_ONLY``, a scene without directional lights, ``local_light_term`` as the
lighting pass's tiles take it; else ``light_contribution``),
from per-pixel light masks computed exactly on the CPU (app/bench/pairs.py) and uploaded
before timing starts: ``u_pixel_masks``, RGBA32UI, ``quads`` texels per pixel side by
side, bit k of the pixel's mask set when light k reaches it. The pass walks a pixel's
mask with the lighting pass's own loop (``add_masked_lights``, glsl/lights/
illumination.glsl), so the two differ only in the mask: a pixel's exact one here, its
tile's in the lighting pass.

Its frame is the G-buffer pass plus this pass: any deferred pipeline rasterises the
surfaces once and evaluates every pair that can add light; culling and the lights a tile's
list holds for the pixel's neighbours but not for the pixel are what the real pipeline
pays on top. (The masks replaced per-pixel index lists, whose texel fetch per pair made
the floor dearer than the culled frame at 16 and 64 lights: docs/performance.md.) The
masks are valid for one camera and one light set only.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.bench.pairs import LightPairs
from app.common.models import BRDF_TERMS
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw
from app.render.fullscreen import read_rgb
from app.render.inputs import SURFACE_ROLES, ShaderInput, ShadingContext, bind_camera
from app.render.renderer import Renderer


def pixel_masks(pairs: LightPairs, quads: int) -> np.ndarray:
    """(H, W, 4 quads) uint32, rows top to bottom: bit k % 32 of word k // 32 set where
    light k reaches the pixel. Each pair sets a distinct bit of its word, so the words are
    sums of distinct powers of two, exact in the float64 of ``np.bincount``."""
    h, w = pairs.count.shape
    words = 4 * quads
    lights = pairs.lights.astype(np.int64)
    slot = pairs.pixel_index() * words + lights // 32
    bit = np.left_shift(1, lights % 32).astype(np.float64)
    flat = np.bincount(slot, weights=bit, minlength=h * w * words)
    return flat.astype(np.uint32).reshape(h, w, words)


def z_target(r: Renderer, hdr: moderngl.Texture) -> moderngl.Framebuffer:
    """``hdr`` with ``r``'s G-buffer z-buffer, depth writes off: what ``shade_gbuffer``
    draws into (the pass is valid for that G-buffer only, as for its camera)."""
    fbo = r.gl.ctx.framebuffer([hdr], r.gbuffer.zbuffer)
    fbo.depth_mask = False
    return fbo


def shade_gbuffer(
    r: Renderer,
    fbo: moderngl.Framebuffer,
    z_fbo: moderngl.Framebuffer,
    draws: list[FullscreenDraw],
    context: ShadingContext,
) -> None:
    """One full-screen pass per draw over ``r``'s G-buffer into ``fbo``, cleared to the
    background first, as the lighting pass draws: every input of ``context`` (the
    G-buffer, material table and lookup tables of the renderer's frame with the pass's own)
    bound and the camera's uniforms set. Like the lighting pass (app/render/lighting.py
    ``run``), the programs' triangle lies on the far plane (their ``FAR_PLANE`` define)
    and is z-tested ">" against the G-buffer's z-buffer, so pixels without a surface never
    run the shader: the comparison with the culled pass is then of the same pixels' work.
    ``z_fbo``: ``fbo``'s target with the z-buffer (``z_target``)."""
    ctx = r.gl.ctx
    fbo.use()
    ctx.viewport = fbo.viewport
    ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
    fbo.clear(*(float(x) for x in r.scene.background), 1.0)
    context.use()
    for draw in draws:
        context.bind(draw.program)
        bind_camera(draw.program, r.camera)
        draw.draw(z_fbo, depth_func=">")


class PixelMasks(ShaderInput):
    """The floor pass's own input: each pixel's exact light mask (``pixel_masks``) in the
    RGBA32UI texture ``u_pixel_masks``, ``TILE_QUADS`` texels per pixel side by side."""

    role = "pixel_masks"

    def __init__(self, ctx: moderngl.Context, pairs: LightPairs, quads: int) -> None:
        self.quads = quads
        masks = pixel_masks(pairs, quads)[::-1]  # GL rows bottom-up
        h, w = masks.shape[:2]
        self.texture = ctx.texture(
            (w * quads, h), 4, np.ascontiguousarray(masks).tobytes(), dtype="u4"
        )
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def defines(self) -> dict[str, int]:
        return {"TILE_QUADS": self.quads}

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        return [("u_pixel_masks", self.texture)]

    def release(self) -> None:
        self.texture.release()


class FloorPass:
    """Shades a ``Renderer``'s G-buffer from exact per-pixel light masks into its own HDR
    target."""

    def __init__(self, renderer: Renderer, pairs: LightPairs) -> None:
        ctx = renderer.gl.ctx
        self.ctx = ctx
        self.renderer = renderer
        self.size = renderer.size
        table = renderer.materials
        several = len(table.models) > 1
        self.quads = max(1, -(-len(renderer.lights) // 128))  # mask texels per pixel
        self.masks = PixelMasks(ctx, pairs, self.quads)
        # the frame's G-buffer, lights (the texture), material and lookup tables, and the
        # masks
        self.context = renderer.shading.only(*SURFACE_ROLES).with_inputs(self.masks)
        frame = self.context.defines()
        self.draws = []
        for group, model in enumerate(table.models):
            defines: dict[str, object] = dict(model.defines())
            defines.update(frame)
            defines["BRDF_TERMS"] = BRDF_TERMS[renderer.scene.render.terms]
            # Without directional lights the walk takes the lighting pass's local term.
            defines["FLOOR_LOCAL_ONLY"] = int(all(x.is_local for x in renderer.lights))
            defines["FAR_PLANE"] = 1  # z-tested to surface pixels (shade_gbuffer)
            if several:
                defines["MODEL_GROUP"] = group
            self.draws.append(
                FullscreenDraw.of(ctx, renderer.shaders, "passes/floor.frag", defines)
            )
        self.programs = [draw.program for draw in self.draws]
        self.hdr = ctx.texture(self.size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self.z_fbo = z_target(renderer, self.hdr)
        self.pairs = pairs

    def run(self) -> None:
        """Shade the renderer's current G-buffer (its G-buffer pass must have run)."""
        shade_gbuffer(self.renderer, self.fbo, self.z_fbo, self.draws, self.context)

    def read_hdr(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        return read_rgb(self.fbo, self.size, "f4")

    def release(self) -> None:
        release_objects(*self.draws, self.z_fbo, self.fbo, self.hdr, self.masks)
