"""The frame: scene -> G-buffer pass -> lighting pass -> post.

``Renderer`` owns the GPU objects of one scene at one size; ``render()`` runs the three
passes, and the ``read_*`` methods bring each stage's result back for output and tests.
"""

from __future__ import annotations

import numpy as np

from app.gl.context import GLContext
from app.gl.shaders import ShaderCache
from app.render.culling import LightCuller, order_lights
from app.render.gbuffer import GBuffer, GBufferData, GBufferPass, material_table
from app.render.lighting import LightingPass
from app.render.post import DofPass, DownsamplePass, PostPass
from app.scene.camera import camera_frame, projection_matrix, view_matrix
from app.scene.geometry import build_parts
from app.scene.lights import environment_records, light_record
from app.scene.loader import LoadedScene


class Renderer:
    """One scene, one image size, headless.

    With ``render.supersample = n`` every pass before post runs at n x n times the pixels
    (``render_size``) and a resolve box-filters the HDR image down to ``size``.
    """

    def __init__(
        self,
        gl: GLContext,
        loaded: LoadedScene,
        size: tuple[int, int] | None = None,
        *,
        uber: bool = False,
        ms_table_size: int | None = None,
    ) -> None:
        """``uber`` and ``ms_table_size`` are bench knobs, not scene keys: one lighting
        program with run-time model selection, and the multiple-scattering table's size
        (app/render/lighting.py LightingPass)."""
        scene = loaded.scene
        self.gl = gl
        self.scene = scene
        self.size = size or (scene.render.width, scene.render.height)
        factor = scene.render.supersample
        self.render_size = (self.size[0] * factor, self.size[1] * factor)
        ctx = gl.ctx
        self.shaders = ShaderCache(ctx)
        records = [light_record(light) for light in scene.lights]
        self.lights = order_lights(records + environment_records(scene.environment))
        parts = build_parts(loaded)
        self.materials, material_ids = material_table(parts)
        tangents = self.materials.needs_tangents
        self.gbuffer = GBuffer(ctx, self.render_size, scene.render.gbuffer, tangents)
        settings = scene.render
        specular_aa = (
            (settings.specular_aa_variance, settings.specular_aa_threshold)
            if settings.specular_aa
            else None
        )
        self.gbuffer_pass = GBufferPass(
            ctx, self.shaders, parts, material_ids, specular_aa, tangents
        )
        local = any(r["type"] != 0 for r in self.lights)
        self.culler = (
            LightCuller(ctx, self.shaders, self.render_size, self.lights)
            if local and scene.render.light_culling == "tiled"
            else None
        )
        self.lighting = LightingPass(
            ctx, self.shaders, self.render_size, self.lights, self.materials, self.culler,
            uber=uber, ms_table_size=ms_table_size, terms=scene.render.terms,
        )  # fmt: skip
        cam = scene.camera
        self.dof = (
            DofPass(ctx, self.shaders, self.render_size, cam.aperture, cam.focus, cam.fov_y)
            if cam.aperture > 0.0
            else None
        )
        self.resolve = DownsamplePass(ctx, self.shaders, self.size, factor) if factor > 1 else None
        self.post = PostPass(ctx, self.shaders, self.size, scene.render.tonemap)
        w, h = self.size
        self.view = view_matrix(scene.camera)
        self.proj = projection_matrix(scene.camera, w / h)
        self.camera = camera_frame(scene.camera, *self.render_size)

    def render(self) -> None:
        """Run all passes; results stay on the GPU until read."""
        scene = self.scene
        self.gbuffer_pass.run(self.gbuffer, self.view, self.proj)
        if self.culler is not None:
            self.culler.run(self.gbuffer, self.view, self.camera)
        self.lighting.run(self.gbuffer, self.camera, np.asarray(scene.background, np.float64))
        hdr = self.lighting.hdr
        if self.dof is not None:
            self.dof.run(hdr, self.gbuffer.depth)
            hdr = self.dof.target
        if self.resolve is not None:
            self.resolve.run(hdr)
            hdr = self.resolve.target
        self.post.run(hdr, scene.camera.exposure)

    def read_hdr(self) -> np.ndarray:
        """Linear HDR radiance before exposure, (H, W, 3) float32, after depth of field
        where the camera has an aperture (resolved to ``size``)."""
        if self.resolve is not None:
            return self.resolve.read()
        return self.dof.read() if self.dof is not None else self.lighting.read()

    def read_ldr(self) -> np.ndarray:
        """The display image, (H, W, 3) uint8 sRGB."""
        return self.post.read()

    def read_gbuffer(self) -> GBufferData:
        return self.gbuffer.read()

    def release(self) -> None:
        if self.culler is not None:
            self.culler.release()
        for extra in (self.resolve, self.dof):
            if extra is not None:
                extra.release()
        for obj in (self.gbuffer_pass, self.gbuffer, self.lighting, self.post, self.shaders):
            obj.release()
