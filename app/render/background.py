"""The environment behind the objects (``[environment] background = true``): a
full-screen pass after lighting that writes the environment's radiance into the HDR
image wherever the G-buffer is empty (glsl/passes/environment_background.frag).

Only scenes that ask for it build the pass, so every other scene renders as before."""

from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.frame.camera import gl_bytes
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer


@dataclass(frozen=True)
class EnvironmentSource:
    """An environment as the passes take it: the equirect map ((H, W, 3) float32 linear
    radiance, row 0 up: app/textures/environment.py), its rotation in degrees about +Y
    and the intensity that scales it."""

    texels: np.ndarray
    rotation: float
    intensity: float


def equirect_texture(
    ctx: moderngl.Context, env_map: np.ndarray, mipmaps: bool = False
) -> moderngl.Texture:
    """The map as an RGBA32F texture, bilinear (trilinear over its mip chain with
    ``mipmaps``), wrapping in u (the seam) and clamped in v (the poles)."""
    h, w = env_map.shape[:2]
    rgba = np.concatenate([env_map, np.ones((h, w, 1), np.float32)], axis=-1)
    texture = ctx.texture((w, h), 4, np.ascontiguousarray(rgba, np.float32), dtype="f4")
    if mipmaps:
        texture.build_mipmaps()
        texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    else:
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
    texture.repeat_x, texture.repeat_y = True, False
    return texture


class EnvironmentBackground:
    """Owns the equirect map's texture (RGBA32F, bilinear, wrapping in u) and the program."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderCache, env: EnvironmentSource) -> None:
        self.ctx = ctx
        self.texture = equirect_texture(ctx, env.texels)
        self.fullscreen = FullscreenDraw.of(ctx, shaders, "passes/environment_background.frag")
        self.rotation = math.radians(env.rotation)
        self.intensity = env.intensity

    def run(self, gbuffer: GBuffer, target: moderngl.Framebuffer, camera: CameraFrame) -> None:
        """Write the background pixels of ``target`` (the lighting pass's HDR target), at
        its own viewport."""
        uniforms = {
            "u_camera_to_world": gl_bytes(camera.camera_to_world),
            "u_tan_half_fov": camera.tan_half_fov,
            "u_rotation": self.rotation,
            "u_intensity": self.intensity,
        }
        textures = {"g_depth": gbuffer.depth, "u_environment": self.texture}
        self.fullscreen.draw(target, uniforms, textures)

    def release(self) -> None:
        for obj in (self.fullscreen, self.texture):
            obj.release()
