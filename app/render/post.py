"""Post: exposure (2^EV), tone mapping and sRGB encoding into an 8-bit image."""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.tonemaps import TONEMAP_CODE
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache
from app.reference import dof
from app.render.fullscreen import FullscreenPass, read_rgb

__all__ = ["DofPass", "DownsamplePass", "PostPass", "read_rgb"]  # read_rgb: moved, kept here


class PostPass(FullscreenPass):
    """HDR texture -> RGBA8 display image: exposure (2^EV), tone map, sRGB encoding.

    ``straight_alpha`` (a transparent background): the HDR image is RGBA premultiplied by
    coverage; the pass divides the colour by alpha before exposure and the tone map and
    writes that alpha, straight, as the display image's (passes/post.frag,
    docs/architecture.md "Alpha"). Without it alpha is 1 and the program is unchanged."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        tonemap: str,
        straight_alpha: bool = False,
    ) -> None:
        defines = {"TONEMAP": TONEMAP_CODE[tonemap]}
        if straight_alpha:
            defines["STRAIGHT_ALPHA"] = 1
        super().__init__(ctx, shaders, "passes/post.frag", defines, size, dtype="f1")
        # run_on_surfaces's program on the far plane (compiled with the pass, so that a
        # frame that first needs it compiles nothing), its triangle made at first use
        self._far_program = shaders.program(
            "passes/fullscreen.vert", "passes/post.frag", {**defines, "FAR_PLANE": 1}
        )
        self._far: FullscreenDraw | None = None
        self._z_fbo: moderngl.Framebuffer | None = None  # target + a G-buffer's z-buffer
        self._z_source: tuple[moderngl.Renderbuffer, moderngl.Texture | None] | None = None
        self._background: tuple[tuple[float, ...], float, tuple[int, ...]] | None = None

    def run(self, hdr: moderngl.Texture, exposure_ev: float) -> None:
        self.draw({"u_exposure": 2.0**exposure_ev}, {"u_hdr": hdr})

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
        if self._far is None:
            self._far = FullscreenDraw(self.ctx, self._far_program)
        self._far.draw(
            self.display_target(zbuffer, background, exposure_ev),
            {"u_exposure": 2.0**exposure_ev},
            {"u_hdr": hdr},
            viewport=(0, 0, *self.size),
            depth_func=">",
        )

    def display_target(
        self,
        zbuffer: moderngl.Renderbuffer,
        background: tuple[float, float, float],
        exposure_ev: float,
        second: moderngl.Texture | None = None,
    ) -> moderngl.Framebuffer:
        """The display image cleared to the value this pass gives ``background``
        (``background_display``), with ``zbuffer`` attached (depth writes off): for a pass
        that then writes the surfaces' pixels only (the lighting pass's ``run_display``).
        ``second``: a second colour attachment, not cleared (the HDR image that
        render.antialiasing = "gbaa" has the lighting pass write too)."""
        value = self.background_display(background, exposure_ev)
        if self._z_fbo is None or self._z_source != (zbuffer, second):
            release_objects(self._z_fbo)
            attachments = [self.target] if second is None else [self.target, second]
            self._z_fbo = self.ctx.framebuffer(attachments, zbuffer)
            self._z_fbo.depth_mask = False
            self._z_source = (zbuffer, second)
        # k / 255 converts back to the byte k in the GL's float -> unorm8 rounding. Cleared
        # through the draw's framebuffer (depth writes off: the z-buffer stays; ``second``
        # masked), so that llvmpipe clears in the draw's scene, not in one of its own.
        # Bound first: moderngl applies a mask to the GL only while its framebuffer is bound.
        self._z_fbo.use()
        if second is not None:
            self._z_fbo.color_mask = ((True,) * 4, (False,) * 4)
        self._z_fbo.clear(*(k / 255.0 for k in value))
        if second is not None:
            self._z_fbo.color_mask = ((True,) * 4, (True,) * 4)
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
            try:
                self.fullscreen.draw(
                    fbo, {"u_exposure": 2.0**exposure_ev}, {"u_hdr": src}, viewport=(0, 0, 1, 1)
                )
                value = tuple(int(b) for b in fbo.read(components=4, alignment=1))
            finally:
                release_objects(fbo, dst, src)
            self._background = (*key, value)
        return self._background[2]

    def release(self) -> None:
        super().release()
        if self._far is not None:
            self._far.release()  # the program is the shader cache's
        release_objects(self._z_fbo)


class DownsamplePass(FullscreenPass):
    """Supersampling's resolve: box-filters an HDR image rendered ``factor`` times larger
    in each direction down to ``size`` (the scene's ``render.supersample``)."""

    def __init__(
        self, ctx: moderngl.Context, shaders: ShaderCache, size: tuple[int, int], factor: int
    ) -> None:
        super().__init__(ctx, shaders, "passes/downsample.frag", None, size)
        self.factor = factor

    def run(self, hdr: moderngl.Texture) -> None:
        self.draw({"u_factor": self.factor}, {"u_hdr": hdr})


class DofPass(FullscreenPass):
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
        defines = {"DOF_SAMPLES": len(offsets)}
        super().__init__(ctx, shaders, "passes/dof.frag", defines, size)
        self.uniforms: dict[str, object] = {
            "u_offsets": np.ascontiguousarray(offsets, np.int32).tobytes(),
            "u_aperture": aperture,
            "u_focus": focus,
            "u_scale": dof.pixels_per_radian(fov_y, size[1]),
            "u_max_coc": dof.MAX_COC,
            "u_min_radius": dof.MIN_RADIUS,
        }

    def run(self, hdr: moderngl.Texture, depth: moderngl.Texture) -> None:
        self.draw(self.uniforms, {"u_hdr": hdr, "u_depth": depth})
