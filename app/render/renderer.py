"""The frame: scene -> G-buffer pass -> lighting pass -> post.

``Renderer`` owns the GPU objects of one scene at one size; ``render()`` runs the three
passes, and the ``read_*`` methods bring each stage's result back for output and tests.
"""

from __future__ import annotations

import numpy as np

from app.gl.context import GLContext
from app.gl.shaders import ShaderCache
from app.render.culling import LightCuller, order_lights
from app.render.gbuffer import GBuffer, GBufferData, GBufferPass
from app.render.lighting import LightingPass
from app.render.materials import MaterialTable
from app.render.post import PostPass
from app.scene.camera import camera_frame, projection_matrix, view_matrix
from app.scene.geometry import build_parts
from app.scene.lights import environment_records, light_record
from app.scene.loader import LoadedScene


class Renderer:
    """One scene, one image size, headless."""

    def __init__(
        self, gl: GLContext, loaded: LoadedScene, size: tuple[int, int] | None = None
    ) -> None:
        scene = loaded.scene
        self.gl = gl
        self.scene = scene
        self.size = size or (scene.render.width, scene.render.height)
        ctx = gl.ctx
        self.shaders = ShaderCache(ctx)
        records = [light_record(light) for light in scene.lights]
        self.lights = order_lights(records + environment_records(scene.environment))
        parts = build_parts(loaded)
        self.materials, material_ids = MaterialTable.build([p.material for p in parts])
        self.gbuffer = GBuffer(ctx, self.size, scene.render.gbuffer)
        self.gbuffer_pass = GBufferPass(ctx, self.shaders, parts, material_ids)
        local = any(r["type"] != 0 for r in self.lights)
        self.culler = (
            LightCuller(ctx, self.shaders, self.size, self.lights)
            if local and scene.render.light_culling == "tiled"
            else None
        )
        self.lighting = LightingPass(
            ctx, self.shaders, self.size, self.lights, self.materials, self.culler
        )
        self.post = PostPass(ctx, self.shaders, self.size, scene.render.tonemap)
        w, h = self.size
        self.view = view_matrix(scene.camera)
        self.proj = projection_matrix(scene.camera, w / h)
        self.camera = camera_frame(scene.camera, *self.size)

    def render(self) -> None:
        """Run all passes; results stay on the GPU until read."""
        scene = self.scene
        self.gbuffer_pass.run(self.gbuffer, self.view, self.proj)
        if self.culler is not None:
            self.culler.run(self.gbuffer, self.view, self.camera)
        self.lighting.run(self.gbuffer, self.camera, np.asarray(scene.background, np.float64))
        self.post.run(self.lighting.hdr, scene.camera.exposure)

    def read_hdr(self) -> np.ndarray:
        """Linear HDR radiance before exposure, (H, W, 3) float32."""
        return self.lighting.read()

    def read_ldr(self) -> np.ndarray:
        """The display image, (H, W, 3) uint8 sRGB."""
        return self.post.read()

    def read_gbuffer(self) -> GBufferData:
        return self.gbuffer.read()

    def release(self) -> None:
        if self.culler is not None:
            self.culler.release()
        for obj in (self.gbuffer_pass, self.gbuffer, self.lighting, self.post, self.shaders):
            obj.release()
