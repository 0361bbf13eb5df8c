"""The G-buffer pass: rasterise every object's material parameters into render targets.

``GBuffer`` allocates, binds and reads back the targets of a ``GBufferLayout``, each of
them by iterating ``GBUFFER_TARGETS`` (app/common/gbuffer.py), the one declaration of the
layout; docs/gbuffer.md documents it:
  RT0 ``base_color``  base colour (linear), metallic; absent with constant surfaces
  RT1 ``normal``      octahedral normal (x, y), perceptual roughness, F0; the normal alone
                      (RG32F) with constant surfaces
  RT2 ``depth``       RG32F: linear view depth in metres (0 where nothing was drawn),
                      material id (an exact integer)
  RT3 ``tangent``     octahedral tangent (x, y), anisotropy, 0; where a material is
                      anisotropic (``GBUFFER_TANGENT``)
  RT4 ``coat_normal`` octahedral clear-coat normal (x, y); where a coat's normal differs
                      from its base's (``GBUFFER_COAT_NORMAL``, RTR4 §9.12)
  RT5 ``emission``    emitted radiance RGB, occlusion factor; where a material emits or has
                      an occlusion map (``GBUFFER_EMISSION``; glTF 2.0)
  z-test              DEPTH24, a renderbuffer, never sampled
each present target at the next framebuffer location, stored as the scene's
``render.gbuffer`` encoding says. ``GBufferPass`` draws every opaque part into it with a
``MeshDrawable`` (app/render/mesh_drawable.py).
"""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import GBUFFER_TARGETS, STORAGE_DTYPES, GBufferData, GBufferLayout
from app.frame.camera import gl_bytes
from app.gl.context import gl_function, release_objects, wait_before_read
from app.gl.shaders import ShaderCache
from app.reference.encoding import unorm_to_snorm
from app.render.mesh_drawable import MeshDrawable, drawn_maps
from app.render.texture_upload import TextureUploads
from app.scene.geometry import MeshPart

__all__ = ["DRAW_RUN", "FLUSH_TRIANGLES", "GBuffer", "GBufferData", "GBufferPass"]


class GBuffer:
    """The render targets of the G-buffer pass: one texture per target of ``layout``, as
    attributes by the targets' names (``base_color``, ``normal``, ``depth``, ``tangent``,
    ``coat_normal``, ``emission``; None where absent), and the z-test's renderbuffer."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], layout: GBufferLayout) -> None:
        """Allocate ``layout``'s targets, each at the location its place in
        ``GBUFFER_TARGETS`` gives it among those present (passes/gbuffer.frag declares
        them there, ``defines``)."""
        self.layout = layout
        self.encoding = layout.encoding
        self.size = size
        self.constant_surfaces = layout.constant_surfaces
        self._targets: list[moderngl.Texture] = []
        self._by_name: dict[str, moderngl.Texture] = {}
        for target, channels in layout.targets():
            tex = ctx.texture(size, channels, dtype=STORAGE_DTYPES[layout.storage(target)])
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = False
            self._targets.append(tex)
            self._by_name[target.name] = tex
        for target in GBUFFER_TARGETS:
            setattr(self, target.name, self._by_name.get(target.name))
        self.zbuffer = ctx.depth_renderbuffer(size)
        self.fbo = ctx.framebuffer(self._targets, self.zbuffer)
        # What a frame clears: RT2 and the z-buffer. Every pass that reads the other
        # targets reads them only where RT2's depth says a surface was drawn (decode.glsl,
        # debug.frag discard the rest), and every drawn fragment writes every target, so
        # their background texels are never read on the GPU; ``read`` gives them the
        # cleared value. Clearing all six took 3.7x as long as these two here
        # (docs/performance.md). Cleared through the pass's own framebuffer, the other
        # targets masked, so that llvmpipe clears in the draws' scene, not in one of its own.
        depth_index = self._targets.index(self._by_name["depth"])
        self._clear_mask = tuple((i == depth_index,) * 4 for i in range(len(self._targets)))
        self._draw_mask = tuple((True,) * 4 for _ in self._targets)

    def clear(self) -> None:
        """Start a frame: no surface anywhere (RT2's depth 0) and the far z. Bound first:
        moderngl applies a framebuffer's mask to the GL only while it is bound, so the
        restored mask would otherwise stay the clear's for the next draw."""
        self.fbo.use()
        self.fbo.color_mask = self._clear_mask
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.fbo.color_mask = self._draw_mask

    def defines(self) -> dict[str, int]:
        """The defines of every pass that writes or decodes these targets
        (``GBufferLayout.defines``): which optional ones exist, the encoding's,
        GBUFFER_CONSTANT_SURFACES where RT0 is absent, and each optional target's
        location."""
        return self.layout.defines()

    def depth_at(self, x: int, y: int) -> float:
        """RT2's view depth at pixel (x, y), rows bottom up: one texel, for picking."""
        wait_before_read(self.fbo.ctx)
        attachment = self.layout.locations()["depth"]  # 1 without RT0
        raw = self.fbo.read(viewport=(x, y, 1, 1), components=2, attachment=attachment,
                            dtype="f4")  # fmt: skip
        return float(np.frombuffer(raw, np.float32)[0])

    def read(self, surfaces: np.ndarray | None = None) -> GBufferData:
        """The targets with GBufferData's float meaning: a unorm target's signed channels
        (``GBufferTarget.signed``) mapped back to [-1, 1] as decode.glsl maps them
        (float64 here, then float32: within an ulp of the GLSL's float32). With constant
        surfaces, ``surfaces`` (``MaterialTable.surface_texels()``) gives each pixel's
        channels of the targets left out or cut short (``GBufferTarget.surface_texel``)
        by its material id, as the decode reads them. A field whose target is absent is
        None, or zeros where ``GBufferData`` has no default for it (``tangent``)."""
        wait_before_read(self.fbo.ctx)
        w, h = self.size
        depth_id = np.frombuffer(self._by_name["depth"].read(), np.float32).reshape(h, w, 2)
        empty = depth_id[..., 0] == 0.0  # no surface: the other targets were not cleared
        rows = None
        if self.constant_surfaces:
            if surfaces is None:
                raise ValueError("a G-buffer of constant surfaces reads with the table's")
            rows = surfaces[np.where(empty, 0, depth_id[..., 1]).astype(np.int64)]
        defaults = {f.name: f.default for f in dataclasses.fields(GBufferData)}
        fields: dict[str, np.ndarray | None] = {}
        for target in GBUFFER_TARGETS:
            tex = self._by_name.get(target.name)
            texels = None
            if target.name == "depth":  # read above; it says where a surface was drawn
                texels = depth_id
            elif tex is not None:
                components = tex.components
                texels = _read_float(tex, target.signed, components)
                texels = texels.reshape(h, w, components).copy()
                texels[empty] = _read_float_of_zero(tex.dtype, target.signed, components)
            if rows is not None and target.surface_texel is not None:
                # constant surfaces: the channels left out, from the pixel's table row
                kept = 0 if texels is None else texels.shape[-1]
                left_out = rows[..., target.surface_texel, : target.channels - kept]
                left_out = np.where(empty[..., None], np.float32(0.0), left_out)
                texels = left_out if texels is None else np.concatenate([texels, left_out], -1)
            for k, name in enumerate(target.fields):
                if texels is not None:
                    value = texels if len(target.fields) == 1 else texels[..., k]
                    fields[name] = value[::-1].copy()
                elif defaults[name] is dataclasses.MISSING:  # a field the twin always reads
                    fields[name] = np.zeros((h, w, target.channels), np.float32)
                else:
                    fields[name] = defaults[name]
        return GBufferData(**fields)

    def texture(self, name: str) -> moderngl.Texture:
        """The target ``name`` of GBUFFER_TARGETS (the transmission pass reads "depth")."""
        return self._by_name[name]

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        """(uniform, texture) of every target a pass decodes (the GLSL declares them as
        GBUFFER_SAMPLERS, gbuffer/decode.glsl), the optional ones only where they exist."""
        return [(t.glsl_name, self._by_name[t.name]) for t, _ in self.layout.targets()]

    def release(self) -> None:
        release_objects(self.fbo, *self._targets, self.zbuffer)


def _read_float(
    tex: moderngl.Texture, signed: tuple[int, ...] = (), components: int = 4
) -> np.ndarray:
    """A texture's texels as float32: float16 widens exactly; a unorm16 texel ``u`` reads
    as u / 65535 (the GL's conversion), and its ``signed`` channels through
    unorm_to_snorm."""
    if tex.dtype != "nu2":
        return np.frombuffer(tex.read(), np.dtype(tex.dtype)).astype(np.float32)
    texels = np.frombuffer(tex.read(), np.uint16).reshape(-1, components) / 65535.0
    texels[:, signed] = unorm_to_snorm(texels[:, signed])
    return texels.astype(np.float32).reshape(-1)


def _read_float_of_zero(dtype: str, signed: tuple[int, ...], components: int) -> np.ndarray:
    """What ``_read_float`` gives for a texel cleared to 0: 0, or -1 in a unorm target's
    signed channels (unorm_to_snorm(0))."""
    value = np.zeros(components, np.float64)
    if dtype == "nu2":
        value[list(signed)] = unorm_to_snorm(value[list(signed)])
    return value.astype(np.float32)


# llvmpipe shades vertices and bins triangles on the calling thread and rasterises a
# frame's binned triangles on its worker threads only at a flush. The G-buffer pass
# flushes once FLUSH_TRIANGLES have been drawn since the last flush, so that the workers
# rasterise those while this thread bins the next ones; a part larger than DRAW_RUN
# triangles is drawn in runs of that many, in its order. The triangles, their order and
# so every target's texels are the same as in one flush at the end; measured on the
# 35-sphere scene in docs/performance.md ("Fixed costs").
FLUSH_TRIANGLES = 4096
DRAW_RUN = 8192


class GBufferPass:
    """Draws every mesh part into a ``GBuffer``; ``material_ids[i]`` are part i's rows of the
    lighting pass's material table, one per layer."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        parts: list[MeshPart],
        material_ids: list[list[int]],
        specular_aa: tuple[float, float] | None = None,
        defines: dict[str, int] | None = None,
        uploads: TextureUploads | None = None,
    ) -> None:
        """``defines``: the targets to write, ``GBuffer.defines()`` of the target it
        draws into. ``uploads``: another pass's material maps to draw with (that pass
        owns and releases them; render.antialiasing = "sraa"'s geometry samples), else
        this pass uploads its own."""
        self.ctx = ctx
        self._gl_flush = gl_function(ctx, "glFlush", [])
        self._unflushed = 0  # triangles drawn since the last flush
        self.flush_triangles = FLUSH_TRIANGLES  # 0: one flush at the end (the bench's "before")
        defines = dict(defines or {"GBUFFER_TANGENT": 1})
        self._owns_uploads = uploads is None
        self.uploads = TextureUploads(ctx, shaders) if uploads is None else uploads
        self.uploads.upload_ready_first((t for p in parts for _, t in drawn_maps(p)), later=True)
        self.drawables = [
            MeshDrawable(
                ctx,
                shaders,
                p,
                ids,
                defines=defines,
                specular_aa=specular_aa,
                uploads=self.uploads,
            )
            for p, ids in zip(parts, material_ids, strict=True)
        ]

    def run(
        self,
        target: GBuffer,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """Draw every part; ``camera`` is the lighting pass's frame (the analytic parts'
        rays must be the lighting pass's)."""
        ctx = self.ctx
        target.fbo.use()
        ctx.viewport = (0, 0, *target.size)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        target.clear()
        target.fbo.use()
        view_bytes, proj_bytes = gl_bytes(view), gl_bytes(proj)
        self._unflushed = 0
        between = self._drawn if self.flush_triangles else None
        for d in self.drawables:
            d.cull(ctx)
            d.draw(view_bytes, proj_bytes, camera, target.size, between, DRAW_RUN)
        ctx.disable(moderngl.CULL_FACE)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def _drawn(self, triangles: int) -> None:
        """Count ``triangles`` drawn; flush once FLUSH_TRIANGLES are waiting (see there)."""
        self._unflushed += triangles
        if self._unflushed >= self.flush_triangles:
            self._gl_flush()
            self._unflushed = 0

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        if self._owns_uploads:
            self.uploads.release()
