"""The environment behind the objects (``[environment] background = true``): a
full-screen pass after lighting that writes the environment's radiance into the HDR
image wherever the G-buffer is empty (glsl/passes/environment_background.frag).

Only scenes that ask for it build the pass, so every other scene renders as before."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.frame.camera import gl_bytes
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer


class EnvironmentBackground:
    """Owns the equirect map's texture (RGBA32F, bilinear, wrapping in u) and the program."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        env_map: np.ndarray,
        rotation: float,
        intensity: float,
    ) -> None:
        """``env_map``: (H, W, 3) float32 linear radiance, row 0 up (app/textures/
        environment.py); ``rotation`` in degrees about +Y; ``intensity`` scales it."""
        self.ctx = ctx
        h, w = env_map.shape[:2]
        rgba = np.concatenate([env_map, np.ones((h, w, 1), np.float32)], axis=-1)
        self.texture = ctx.texture((w, h), 4, np.ascontiguousarray(rgba, np.float32), dtype="f4")
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x, self.texture.repeat_y = True, False
        self.program = shaders.program(
            "passes/fullscreen.vert", "passes/environment_background.frag", {}
        )
        self.vao = ctx.vertex_array(self.program, [])
        self.rotation = math.radians(rotation)
        self.intensity = intensity

    def run(self, gbuffer: GBuffer, target: moderngl.Framebuffer, camera: CameraFrame) -> None:
        """Write the background pixels of ``target`` (the lighting pass's HDR target)."""
        target.use()
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        gbuffer.depth.use(0)
        self.texture.use(1)
        prog = self.program
        prog["g_depth"].value = 0
        prog["u_environment"].value = 1
        prog["u_camera_to_world"].write(gl_bytes(camera.camera_to_world))
        prog["u_tan_half_fov"].value = camera.tan_half_fov
        prog["u_rotation"].value = self.rotation
        prog["u_intensity"].value = self.intensity
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        for obj in (self.vao, self.texture):
            obj.release()
