"""Post: exposure (2^EV), tone mapping and sRGB encoding into an 8-bit image."""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.tonemaps import TONEMAP_CODE
from app.gl.shaders import ShaderCache
from app.reference import dof


def read_rgb(fbo: moderngl.Framebuffer, size: tuple[int, int], dtype: str) -> np.ndarray:
    """``fbo``'s first attachment as (H, W, 3) float32 ("f4") or uint8 ("f1"), rows top to
    bottom. GL packs the three channels (glReadPixels with GL_RGB, rows 1-byte aligned),
    so the only copy in numpy is the row flip, a contiguous copy per row: reading RGBA and
    slicing off alpha, a strided copy, took 4x as long for 1280x720 RGBA8 here
    (docs/performance.md). The values are the same bytes either way."""
    w, h = size
    data = fbo.read(components=3, alignment=1, dtype=dtype)
    return (
        np.frombuffer(data, np.float32 if dtype == "f4" else np.uint8).reshape(h, w, 3)[::-1].copy()
    )


class _FullscreenPass:
    """A full-screen pass of ``program`` into its own RGBA target of ``size`` (``dtype``
    "f4": linear HDR, NEAREST; "f1": the 8-bit display image): what every image-to-image
    pass shares."""

    def __init__(
        self,
        ctx: moderngl.Context,
        program: moderngl.Program,
        size: tuple[int, int],
        dtype: str = "f4",
    ) -> None:
        self.ctx = ctx
        self.program = program
        self.vao = ctx.vertex_array(program, [])
        self.target = ctx.texture(size, 4, dtype=dtype)
        self.target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = ctx.framebuffer([self.target])
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
        """(H, W, 3) float32 (HDR) or uint8 (display), rows top to bottom."""
        return read_rgb(self.fbo, self.size, self.target.dtype)

    def release(self) -> None:
        for obj in (self.vao, self.fbo, self.target):
            obj.release()


class PostPass(_FullscreenPass):
    """HDR texture -> RGBA8 display image: exposure (2^EV), tone map, sRGB encoding."""

    def __init__(
        self, ctx: moderngl.Context, shaders: ShaderCache, size: tuple[int, int], tonemap: str
    ) -> None:
        program = shaders.program(
            "passes/fullscreen.vert", "passes/post.frag", {"TONEMAP": TONEMAP_CODE[tonemap]}
        )
        super().__init__(ctx, program, size, dtype="f1")

    def run(self, hdr: moderngl.Texture, exposure_ev: float) -> None:
        self._draw({"u_hdr": hdr}, {"u_exposure": 2.0**exposure_ev})


class DownsamplePass(_FullscreenPass):
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


class DofPass(_FullscreenPass):
    """Thin-lens depth of field (RTR4 §9.2) on linear HDR: each pixel's radiance
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
