"""The floor pass: what no lighting pipeline can go under (issue 5's ``floor`` variant).

A bare full-screen pass (glsl/passes/floor.frag) that decodes the G-buffer and evaluates
the lighting pass's ``light_at`` and ``brdf_eval`` exactly once per (pixel, light in range)
pair, from per-pixel lists computed exactly on the CPU (app/bench/pairs.py) and uploaded
before timing starts:

* ``u_pair_ranges`` RG32UI, one texel per pixel: (first pair, number of pairs);
* ``u_pair_lights`` R32UI, PAIR_ROW texels per row: the light index of each pair, a
  pixel's lights contiguous and ascending, as the lighting pass visits them.

Its frame is the G-buffer pass plus this pass: any deferred pipeline rasterises the
surfaces once and evaluates every pair that can add light; culling, bit scanning and
lights a tile's list holds for the pixel's neighbours but not for the pixel are what the
real pipeline pays on top. The lists are valid for one camera and one light set only.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.bench.pairs import LightPairs
from app.render.renderer import Renderer
from app.scene.camera import gl_bytes

PAIR_ROW = 4096  # texels per row of the pair texture (the GL 3.3 minimum maximum is 1024;
#                  llvmpipe and every current GPU take 16384)


class FloorPass:
    """Shades a ``Renderer``'s G-buffer from exact light lists into its own HDR target."""

    def __init__(self, renderer: Renderer, pairs: LightPairs) -> None:
        ctx = renderer.gl.ctx
        self.ctx = ctx
        self.renderer = renderer
        self.size = renderer.size
        table = renderer.materials
        several = len(table.models) > 1
        self.programs = []
        for group, model in enumerate(table.models):
            defines: dict[str, object] = dict(model.defines())
            defines["PAIR_ROW"] = PAIR_ROW
            defines["GBUFFER_TANGENT"] = int(table.needs_tangents)
            if several:
                defines["MODEL_GROUP"] = group
            self.programs.append(
                renderer.shaders.program("passes/fullscreen.vert", "passes/floor.frag", defines)
            )
        self.vaos = [ctx.vertex_array(prog, []) for prog in self.programs]
        w, h = self.size
        ranges = np.stack([pairs.first, pairs.count], axis=-1)[::-1]  # GL rows bottom-up
        self.ranges = ctx.texture(
            (w, h), 2, np.ascontiguousarray(ranges, np.uint32).tobytes(), dtype="u4"
        )
        rows = max(1, -(-pairs.total // PAIR_ROW))
        flat = np.zeros(rows * PAIR_ROW, np.uint32)
        flat[: pairs.total] = pairs.lights
        self.pair_lights = ctx.texture((PAIR_ROW, rows), 1, flat.tobytes(), dtype="u4")
        for tex in (self.ranges, self.pair_lights):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.hdr = ctx.texture(self.size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self.pairs = pairs

    def run(self) -> None:
        """Shade the renderer's current G-buffer (its G-buffer pass must have run)."""
        ctx, r = self.ctx, self.renderer
        self.fbo.use()
        ctx.viewport = (0, 0, *self.size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self.fbo.clear(*(float(x) for x in r.scene.background), 1.0)
        textures = [
            ("g_albedo", r.gbuffer.albedo),
            ("g_normal", r.gbuffer.normal),
            ("g_depth", r.gbuffer.depth),
            *([("g_tangent", r.gbuffer.tangent)] if r.gbuffer.tangent is not None else []),
            ("u_lights", r.lighting.lights),
            ("u_materials", r.lighting.materials),
            ("u_pair_ranges", self.ranges),
            ("u_pair_lights", self.pair_lights),
        ]
        if r.lighting.ms_table is not None:
            textures.append(("u_ms_table", r.lighting.ms_table))
        for unit, (_, tex) in enumerate(textures):
            tex.use(unit)
        camera_to_world = gl_bytes(r.camera.camera_to_world)
        for prog, vao in zip(self.programs, self.vaos, strict=True):
            for unit, (name, _) in enumerate(textures):
                if name in prog:
                    prog[name].value = unit
            prog["u_camera_pos"].value = tuple(float(x) for x in r.camera.position)
            prog["u_camera_to_world"].write(camera_to_world)
            prog["u_tan_half_fov"].value = r.camera.tan_half_fov
            vao.render(moderngl.TRIANGLES, vertices=3)

    def read_hdr(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        w, h = self.size
        data = np.frombuffer(self.hdr.read(), np.float32).reshape(h, w, 4)
        return data[::-1, :, :3].copy()

    def release(self) -> None:
        for obj in (*self.vaos, self.fbo, self.hdr, self.ranges, self.pair_lights):
            obj.release()
