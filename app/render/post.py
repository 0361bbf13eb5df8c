"""Post: exposure (2^EV), tone mapping and sRGB encoding into an 8-bit image."""

from __future__ import annotations

import moderngl
import numpy as np

from app.gl.shaders import ShaderCache
from app.reference import dof
from app.reference.tonemap import TONEMAPS

# The TONEMAP define of glsl/passes/post.frag, in the order of the twin's list.
TONEMAP_CODE = {name: code for code, name in enumerate(TONEMAPS)}


class PostPass:
    """HDR texture -> RGBA8 display image."""

    def __init__(
        self, ctx: moderngl.Context, shaders: ShaderCache, size: tuple[int, int], tonemap: str
    ) -> None:
        self.ctx = ctx
        self.program = shaders.program(
            "passes/fullscreen.vert", "passes/post.frag", {"TONEMAP": TONEMAP_CODE[tonemap]}
        )
        self.vao = ctx.vertex_array(self.program, [])
        self.ldr = ctx.texture(size, 4)
        self.fbo = ctx.framebuffer([self.ldr])
        self.size = size

    def run(self, hdr: moderngl.Texture, exposure_ev: float) -> None:
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        hdr.use(0)
        self.program["u_hdr"].value = 0
        self.program["u_exposure"].value = 2.0**exposure_ev
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def read(self) -> np.ndarray:
        """(H, W, 3) uint8, rows top to bottom."""
        w, h = self.size
        data = np.frombuffer(self.ldr.read(), np.uint8).reshape(h, w, 4)
        return data[::-1, :, :3].copy()

    def release(self) -> None:
        for obj in (self.vao, self.fbo, self.ldr):
            obj.release()


class _HdrPass:
    """A full-screen pass of ``program`` into its own RGBA32F target of ``size``: the
    shared part of the passes that turn one linear HDR image into another."""

    def __init__(
        self, ctx: moderngl.Context, program: moderngl.Program, size: tuple[int, int]
    ) -> None:
        self.ctx = ctx
        self.program = program
        self.vao = ctx.vertex_array(program, [])
        self.hdr = ctx.texture(size, 4, dtype="f4")
        self.hdr.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.hdr])
        self.size = size

    def _draw(self, textures: dict[str, moderngl.Texture], uniforms: dict[str, object]) -> None:
        """Bind ``textures`` to units 0, 1, ... and set ``uniforms`` (every run: a shader
        cache may hand the same program to passes of other parameters), then draw."""
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        for unit, (name, tex) in enumerate(textures.items()):
            tex.use(unit)
            self.program[name].value = unit
        for name, value in uniforms.items():
            if isinstance(value, bytes):
                self.program[name].write(value)
            else:
                self.program[name].value = value
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def read(self) -> np.ndarray:
        """(H, W, 3) float32, rows top to bottom."""
        w, h = self.size
        data = np.frombuffer(self.hdr.read(), np.float32).reshape(h, w, 4)
        return data[::-1, :, :3].copy()

    def release(self) -> None:
        for obj in (self.vao, self.fbo, self.hdr):
            obj.release()


class DownsamplePass(_HdrPass):
    """Supersampling's resolve: box-filters an HDR image rendered ``factor`` times larger
    in each direction down to ``size`` (the scene's ``render.supersample``)."""

    def __init__(
        self, ctx: moderngl.Context, shaders: ShaderCache, size: tuple[int, int], factor: int
    ) -> None:
        super().__init__(
            ctx, shaders.program("passes/fullscreen.vert", "passes/downsample.frag"), size
        )
        self.factor = factor

    def run(self, hdr: moderngl.Texture) -> None:
        self._draw({"u_hdr": hdr}, {"u_factor": self.factor})


class DofPass(_HdrPass):
    """Thin-lens depth of field (seed section 2) on linear HDR: each pixel's radiance
    spread over its circle of confusion (glsl/passes/dof.frag, twin app/reference/dof.py).
    Built only for a camera with an aperture: a pinhole camera skips the pass."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        aperture: float,
        focus: float,
        fov_y: float,
    ) -> None:
        offsets = dof.gather_offsets()
        program = shaders.program(
            "passes/fullscreen.vert", "passes/dof.frag", {"DOF_SAMPLES": len(offsets)}
        )
        super().__init__(ctx, program, size)
        self.uniforms: dict[str, object] = {
            "u_offsets": np.ascontiguousarray(offsets, np.int32).tobytes(),
            "u_aperture": aperture,
            "u_focus": focus,
            "u_scale": dof.pixels_per_radian(fov_y, size[1]),
            "u_max_coc": dof.MAX_COC,
            "u_min_radius": dof.MIN_RADIUS,
        }

    def run(self, hdr: moderngl.Texture, depth: moderngl.Texture) -> None:
        self._draw({"u_hdr": hdr, "u_depth": depth}, self.uniforms)
