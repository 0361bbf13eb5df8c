"""Post: exposure (2^EV), tone mapping and sRGB encoding into an 8-bit image."""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.tonemaps import TONEMAP_CODE
from app.gl.context import wait_before_read
from app.gl.shaders import ShaderCache
from app.reference import dof


def read_rgb(
    fbo: moderngl.Framebuffer, size: tuple[int, int], dtype: str, scratch: bytearray | None = None
) -> np.ndarray:
    """``fbo``'s first attachment as (H, W, 3) float32 ("f4") or uint8 ("f1"), rows top to
    bottom. GL packs the three channels (glReadPixels with GL_RGB, rows 1-byte aligned),
    so the only copy in numpy is the row flip, a contiguous copy per row: reading RGBA and
    slicing off alpha, a strided copy, took 4x as long for 1280x720 RGBA8 here
    (docs/performance.md). ``scratch``: a buffer of the packed image's size to read into,
    kept by a caller that reads every frame (fresh memory for each read is paged in
    again; docs/performance.md, "The fused display image"). The same bytes either way."""
    w, h = size
    wait_before_read(fbo.ctx)
    item = np.dtype(np.float32 if dtype == "f4" else np.uint8)
    if scratch is None:
        data: bytes | bytearray = fbo.read(components=3, alignment=1, dtype=dtype)
    else:
        fbo.read_into(scratch, components=3, alignment=1, dtype=dtype)
        data = scratch
    out = np.empty((h, w, 3), item)
    np.copyto(out, np.frombuffer(data, item, h * w * 3).reshape(h, w, 3)[::-1])
    return out


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
        self._scratch: bytearray | None = None  # read: the display image's read buffer
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
        """(H, W, 3) float32 (HDR) or uint8 (display), rows top to bottom; the display
        image through a buffer kept for the next read (``read_rgb``)."""
        if self.target.dtype != "f1":
            return read_rgb(self.fbo, self.size, self.target.dtype)
        if self._scratch is None:
            self._scratch = bytearray(self.size[0] * self.size[1] * 3)
        return read_rgb(self.fbo, self.size, "f1", self._scratch)

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
        # run_on_surfaces's program on the far plane (compiled with the pass, so that a
        # frame that first needs it compiles nothing) and its triangle, made at first use
        defines = {"TONEMAP": TONEMAP_CODE[tonemap], "FAR_PLANE": 1}
        self._far_program = shaders.program("passes/fullscreen.vert", "passes/post.frag", defines)
        self._far_vao: moderngl.VertexArray | None = None
        self._z_fbo: moderngl.Framebuffer | None = None  # target + a G-buffer's z-buffer
        self._z_source: moderngl.Renderbuffer | None = None
        self._background: tuple[tuple[float, ...], float, tuple[int, ...]] | None = None

    def run(self, hdr: moderngl.Texture, exposure_ev: float) -> None:
        self._draw({"u_hdr": hdr}, {"u_exposure": 2.0**exposure_ev})

    def run_on_surfaces(
        self,
        hdr: moderngl.Texture,
        exposure_ev: float,
        zbuffer: moderngl.Renderbuffer,
        background: tuple[float, float, float],
    ) -> None:
        """``run`` for an HDR image whose pixels without a surface in ``zbuffer`` all hold
        ``background``: the pass runs only where the z-test (">", on the far plane, no
        writes) finds a surface, over ``display_target``'s cleared image; the bytes are
        ``run``'s (docs/performance.md, "Fixed costs")."""
        prog = self._far_program
        if self._far_vao is None:
            self._far_vao = self.ctx.vertex_array(prog, [])
        vao = self._far_vao
        self.display_target(zbuffer, background, exposure_ev).use()
        ctx = self.ctx
        ctx.viewport = (0, 0, *self.size)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"
        hdr.use(0)
        prog["u_hdr"].value = 0
        prog["u_exposure"].value = 2.0**exposure_ev
        vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"

    def display_target(
        self,
        zbuffer: moderngl.Renderbuffer,
        background: tuple[float, float, float],
        exposure_ev: float,
    ) -> moderngl.Framebuffer:
        """The display image cleared to the value this pass gives ``background``
        (``background_display``), with ``zbuffer`` attached (depth writes off): for a pass
        that then writes the surfaces' pixels only (the lighting pass's ``run_display``)."""
        value = self.background_display(background, exposure_ev)
        if self._z_fbo is None or self._z_source is not zbuffer:
            if self._z_fbo is not None:
                self._z_fbo.release()
            self._z_fbo = self.ctx.framebuffer([self.target], zbuffer)
            self._z_fbo.depth_mask = False
            self._z_source = zbuffer
        # k / 255 converts back to the byte k in the GL's float -> unorm8 rounding.
        self.fbo.clear(*(k / 255.0 for k in value))
        return self._z_fbo

    def background_display(
        self, background: tuple[float, float, float], exposure_ev: float
    ) -> tuple[int, ...]:
        """The RGBA bytes this pass writes for an HDR texel (background, 1): this pass's
        own program run on a 1x1 image, so the value is the GPU's to the bit; kept until
        the background or exposure changes (the read waits for the GPU once)."""
        key = (tuple(float(x) for x in background), float(exposure_ev))
        if self._background is None or self._background[:2] != key:
            ctx = self.ctx
            texel = np.array([*key[0], 1.0], np.float32)
            src = ctx.texture((1, 1), 4, texel.tobytes(), dtype="f4")
            dst = ctx.texture((1, 1), 4, dtype="f1")
            fbo = ctx.framebuffer([dst])
            vao = ctx.vertex_array(self.program, [])
            try:
                fbo.use()
                ctx.viewport = (0, 0, 1, 1)
                src.use(0)
                self.program["u_hdr"].value = 0
                self.program["u_exposure"].value = 2.0**exposure_ev
                vao.render(moderngl.TRIANGLES, vertices=3)
                value = tuple(int(b) for b in fbo.read(components=4, alignment=1))
            finally:
                for obj in (vao, fbo, dst, src):
                    obj.release()
            self._background = (*key, value)
        return self._background[2]

    def release(self) -> None:
        super().release()
        if self._far_vao is not None:
            self._far_vao.release()  # the program is the shader cache's
        if self._z_fbo is not None:
            self._z_fbo.release()


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
