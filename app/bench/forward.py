"""A plain forward renderer: the baseline the deferred pipeline has to beat in the bench.

Every object is drawn once into an RGBA32F target with a depth test, and each fragment
loops over every light of the scene with the lighting pass's own ``light_at`` and
``brdf_eval`` (glsl/passes/forward.frag), in the deferred renderer's light order, so the
two images agree to float32 rounding (tests/test_bench.py). What differs is where the
work goes:

* no G-buffer: the surface comes from the material's uniforms and the interpolated
  normal and tangent, so nothing is quantised to 16 bits; the world position is
  reconstructed from the interpolated view depth as the lighting pass does;
* no light culling: a fragment pays for every light, in range or not;
* overdraw: a fragment shaded before something nearer covers it is shaded for nothing.
  Objects are drawn nearest first (by the distance of their origin from the camera), the
  usual cheap help for the early depth test; there is no depth pre-pass.

Material numbers of the optional BRDF models come from the same material table as the
lighting pass (``u_material_id`` selects the row); one program per model group and per
texture-map combination, as the G-buffer pass compiles them.
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.frame import prepare_frame
from app.frame.camera import camera_frame, gl_bytes, projection_matrix, view_matrix
from app.gl.context import GLContext, release_objects
from app.gl.shaders import ShaderCache
from app.render.blend import forward_drawables
from app.render.inputs import bind_camera, shading_context
from app.scene.loader import LoadedScene


class ForwardRenderer:
    """One scene, one image size, headless; ``render()`` then ``read_hdr()``."""

    def __init__(
        self, gl: GLContext, loaded: LoadedScene, size: tuple[int, int] | None = None
    ) -> None:
        scene = loaded.scene
        self.gl = gl
        self.scene = scene
        self.size = size or (scene.render.width, scene.render.height)
        ctx = gl.ctx
        self.ctx = ctx
        self.shaders = ShaderCache(ctx)
        # The deferred renderer's frame: the same lights in the same order, so each pixel
        # sums the same terms in the same order, and the same material table.
        frame = prepare_frame(loaded)
        self.lights = frame.lights
        self.materials = frame.materials
        parts, material_ids = frame.parts, frame.material_ids
        # The shader inputs (app/render/inputs.py) the renderer's frame would have, but no
        # G-buffer: the light texture, the material table and the lookup tables its models
        # read; the layers' maps are bound on the units after theirs.
        self.context = shading_context(ctx, self.lights, self.materials)
        settings = scene.render
        specular_aa = (
            (settings.specular_aa_variance, settings.specular_aa_threshold)
            if settings.specular_aa
            else None
        )
        # One drawable per part and model group (app/render/blend.py, which the renderer's
        # blend pass shares).
        self.drawables = forward_drawables(
            ctx,
            self.shaders,
            parts,
            material_ids,
            self.materials,
            settings.terms,
            specular_aa,
            self.context.defines(),
        )
        self.hdr = ctx.texture(self.size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.zbuffer = ctx.depth_renderbuffer(self.size)
        self.fbo = ctx.framebuffer([self.hdr], self.zbuffer)
        w, h = self.size
        self.view = view_matrix(scene.camera)
        self.proj = projection_matrix(scene.camera, w / h)
        self.camera = camera_frame(scene.camera, w, h)
        # Nearest first: the early depth test then skips more of what is hidden.
        eye = np.asarray(scene.camera.position, np.float64)
        self.drawables.sort(key=lambda d: float(np.linalg.norm(d.part.model[:3, 3] - eye)))

    def render(self) -> None:
        """Draw every object once, each fragment summing over every light."""
        ctx = self.ctx
        self.fbo.use()
        ctx.viewport = (0, 0, *self.size)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        background = (float(x) for x in self.scene.background)
        self.fbo.clear(*background, 1.0, depth=1.0)
        view_bytes, proj_bytes = gl_bytes(self.view), gl_bytes(self.proj)
        image_size = tuple(float(x) for x in self.size)
        first_map = self.context.use()
        for d in self.drawables:
            d.cull(ctx)  # as the G-buffer pass
            prog = d.program
            d.bind_transform(view_bytes, proj_bytes)
            d.bind_camera(self.camera, self.size)
            bind_camera(prog, self.camera)
            d.bind_material(first_unit=first_map)
            if "u_image_size" in prog:  # the compiler drops what a permutation does not use
                prog["u_image_size"].value = image_size
            self.context.bind(prog)
            d.vao.render(moderngl.TRIANGLES)
        ctx.disable(moderngl.CULL_FACE)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def read_hdr(self) -> np.ndarray:
        """Linear HDR radiance, (H, W, 3) float32, rows top to bottom."""
        w, h = self.size
        data = np.frombuffer(self.hdr.read(), np.float32).reshape(h, w, 4)
        return data[::-1, :, :3].copy()

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        release_objects(self.fbo, self.hdr, self.zbuffer)
        self.context.release()
        self.shaders.release()
