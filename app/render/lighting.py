"""The lighting pass: the seed's illumination sum over the G-buffer, into linear HDR.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (seed section 4), evaluated by
glsl/passes/lighting.frag into an RGBA32F target. Lights travel in an RGBA32F texture
(4 texels per light, one light per row), so their number is bounded only by the
texture height, not by uniform-block limits.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer
from app.scene.camera import CameraFrame, gl_bytes
from app.scene.lights import pack_lights


class LightingPass:
    """Owns the HDR target and the light texture."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        records: list[dict],
    ) -> None:
        self.ctx = ctx
        self.program = shaders.program("passes/fullscreen.vert", "passes/lighting.frag")
        self.vao = ctx.vertex_array(self.program, [])
        self.hdr = ctx.texture(size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        packed = pack_lights(records)
        self.lights = ctx.texture((4, packed.shape[0]), 4, packed.tobytes(), dtype="f4")
        self.lights.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.light_count = len(records)
        self.size = size

    def run(
        self,
        gbuffer: GBuffer,
        camera: CameraFrame,
        background: np.ndarray,
    ) -> None:
        ctx, prog = self.ctx, self.program
        self.fbo.use()
        ctx.viewport = (0, 0, *self.size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        gbuffer.albedo.use(0)
        gbuffer.normal.use(1)
        gbuffer.depth.use(2)
        self.lights.use(3)
        for name, unit in (("g_albedo", 0), ("g_normal", 1), ("g_depth", 2), ("u_lights", 3)):
            prog[name].value = unit
        prog["u_light_count"].value = self.light_count
        prog["u_camera_pos"].value = tuple(float(x) for x in camera.position)
        prog["u_camera_to_world"].write(gl_bytes(camera.camera_to_world))
        prog["u_tan_half_fov"].value = camera.tan_half_fov
        prog["u_background"].value = tuple(float(x) for x in background)
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def read(self) -> np.ndarray:
        """The HDR image, (H, W, 3) float32, rows top to bottom."""
        w, h = self.size
        data = np.frombuffer(self.hdr.read(), np.float32).reshape(h, w, 4)
        return data[::-1, :, :3].copy()

    def release(self) -> None:
        for obj in (self.vao, self.fbo, self.hdr, self.lights):
            obj.release()
