"""Debug views of ``pbs render --debug VIEW``: one quantity of the frame per pixel.

A ``DebugPass`` is built from a ``Renderer`` after ``render()`` and reuses its G-buffer,
light and material textures and tile masks: ``run(view, light)`` evaluates the view on the
GPU (glsl/passes/debug.frag) into raw float32 values at the G-buffer's size
(``render_size``), ``read_values()`` brings them back, and ``read_display()`` and the
RGBA8 texture ``display`` (what the desktop viewer draws) hold the display image.

Raw values (``read_values()``, (H, W, 4) float32, rows top to bottom): RGB the quantity (a
scalar repeated in R, G and B), A 1 where it is defined and 0 on the background, which no
surface covers. The BRDF views (``fresnel`` ... ``light``) evaluate one light, index
``light`` into ``renderer.lights``, with each pixel's own model (one program per model
group, as the lighting pass compiles them), and are 0 where that light is below the
surface (n.l <= 0), as brdf_eval is there. ``f0`` is compiled per model group too: the
dielectric F0 takes the specular colour (glTF KHR_materials_specular) only where the
group's ``SPECULAR_COLOR`` says so, as in the lighting pass.

How raw values become display bytes (``display_image``; "sRGB" is the sRGB transfer
function of a linear value clamped to [0, 1], "grey" the value clamped to [0, 1] times 255):

=================  ============================================  ==========================
view               raw value                                     display
=================  ============================================  ==========================
``base_color``     linear base colour as stored (F0 of metals)   sRGB
``normal``         unit world normal n (as shaded)               n * 0.5 + 0.5, per channel
``roughness``      perceptual roughness r as stored              grey
``metallic``       metallic as stored                            grey
``f0``             F0, RGB: the F0 the lights' Fresnel takes      sRGB (0.04 -> 56 of 255)
                   (material_F0: the dielectric F0 times the
                   specular colour and its texture, the base
                   colour for a metal, mixed by metallic)
``depth``          linear view depth, metres                     near (frame min) white to
                                                                 far (max) 10% grey
``material_id``    the material table's row                      ``PALETTE[id % 12]``
``coat_normal``    unit clear-coat normal (RT4; the normal n     nc * 0.5 + 0.5
                   where the frame has no RT4)
``fresnel``        F(h, l), RGB (RTR4 §9.5)                      sRGB
``ndf``            D(h) (RTR4 §9.7-9.8), 0 ... ~1e5              grey of a log scale:
                                                                 1e-3 black, 1 mid grey,
                                                                 1e3 and above white
``g2``             G2(l, v, h) (RTR4 §9.7), 0 ... 1               grey
``specular``       f_spec (+ f_ms), RGB, sr^-1 (RTR4 §9.8)       sRGB of x / (1 + x),
                                                                 x = pi f_spec
``diffuse``        f_diffuse, RGB, sr^-1 (RTR4 §9.9)             same, x = pi f_diffuse
``light``          pi f c_light (n.l)+ of the light, RGB         sRGB of x / (1 + x)
``tiles``          local lights in the pixel's 8x8 tile          ``tile_ramp``: a fixed
                   (popcount of the culler's mask)               heat ramp on log2(1 + n)
``emission``       emitted radiance, RGB (RT5; 0 without it)     sRGB of x / (1 + x)
``occlusion``      the occlusion factor on environment light      grey
                   (RT5; 1 without it; glTF 2.0)
``nan``            the HDR image (app/render/debug.py)           its NaN/Inf view
=================  ============================================  ==========================

Background pixels (A = 0) are black in every view but ``tiles``, which covers the image.
pi f makes the scale of a reflectance: a white Lambertian surface has pi f_diffuse = 1,
shown at x / (1 + x) = 0.5 (sRGB 188); x / (1 + x) keeps the order of values up to the
specular peaks without clipping. D spans eight decades between a smooth peak and a tail,
and the tails are what tell GGX from Beckmann (RTR4 §9.8, scenes/sec8_ndf.toml), so it
goes through a log scale: (log10 D + 3) / 6. Peaks above 1e3 (smooth surfaces: up
to 1/(pi alpha_min^2) = 7.8e4 for GGX) clip to white. The tile ramp is the same for every frame
(1 light blue, 3 cyan, 7 green, 15 yellow, 31 orange, 63 red, 127 magenta, 255
and more white), so images of two
scenes compare. ``tiles`` counts only local lights: directional ones reach every tile and
have no mask bits; a frame without tile culling (no local lights,
``render.light_culling = "none"``, or "auto" with fewer local lights than
app/render/culling.py TILED_MIN_LOCAL_LIGHTS: set "tiled" to see them) gives zero
everywhere. ``nan`` is the view of
app/render/debug.py at the output size (after the supersampling resolve).
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.debug_views import DEBUG_VIEW_CODE, DEBUG_VIEWS, LIGHT_VIEWS
from app.common.models import BRDF_TERMS
from app.gl.context import release_objects, wait_before_read
from app.gl.fullscreen import FullscreenDraw
from app.render.culling import LightCuller, tiles_used
from app.render.debug import BadPixels, nan_debug_image
from app.render.inputs import (
    GBUFFER,
    LIGHTS,
    MATERIALS,
    SURFACE_ROLES,
    ShadingContext,
    bind_camera,
)  # fmt: skip
from app.render.lighting import LightingPass
from app.render.renderer import Renderer

# Views whose values come straight from the G-buffer (the G-buffer's texels, exactly).
GBUFFER_VIEWS = (
    "base_color", "normal", "roughness", "metallic", "depth", "material_id", "coat_normal",
)  # fmt: skip
# Views compiled once per model group (the model's defines), as the lighting pass is: the
# BRDF views and F0 (whose specular colour only a group with SPECULAR_COLOR reads).
MODEL_VIEWS = (*LIGHT_VIEWS, "f0")

# material_id: 12 colours far apart in hue and lightness (index = id % 12).
PALETTE = np.array(
    [
        (230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48),
        (145, 30, 180), (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212),
        (0, 128, 128), (170, 110, 40),
    ],
    np.uint8,
)  # fmt: skip

# tiles: (position on the ramp, colour) stops; the position of n lights is log2(1 + n) / 8.
TILE_RAMP = (
    (0.0, (0, 0, 0)),  # no light
    (0.125, (40, 60, 255)),  # 1 light: blue
    (0.25, (0, 200, 230)),  # 3: cyan
    (0.375, (40, 210, 60)),  # 7: green
    (0.5, (250, 230, 40)),  # 15: yellow
    (0.625, (250, 130, 20)),  # 31: orange
    (0.75, (220, 30, 30)),  # 63: red
    (0.875, (230, 60, 230)),  # 127: magenta
    (1.0, (255, 255, 255)),  # 255 and more: white
)

NDF_LOG_MIN = -3.0  # ndf: log10 D of black
NDF_LOG_DECADES = 6.0  # ... to white at D = 1e3 (D = 1 mid grey)
DEPTH_FAR_GREY = 0.1  # the farthest surface's grey: above the black background


def srgb_encode(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values clamped to [0, 1]."""
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64), nan=0.0), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_bytes(x: np.ndarray) -> np.ndarray:
    """Values in [0, 1] (clamped; NaN to 0) -> uint8."""
    x = np.clip(np.nan_to_num(np.asarray(x, np.float64), nan=0.0), 0.0, 1.0)
    return np.rint(x * 255.0).astype(np.uint8)


def compress(x: np.ndarray) -> np.ndarray:
    """x / (1 + x) for x >= 0: 0 -> 0, 1 -> 0.5, infinity -> 1 (negatives to 0)."""
    x = np.maximum(np.nan_to_num(np.asarray(x, np.float64), nan=0.0, posinf=1e30), 0.0)
    return x / (1.0 + x)


def tile_ramp(count: np.ndarray) -> np.ndarray:
    """(...,) light counts -> (..., 3) uint8 on the fixed heat ramp TILE_RAMP."""
    t = np.clip(np.log2(1.0 + np.maximum(np.asarray(count, np.float64), 0.0)) / 8.0, 0.0, 1.0)
    stops = np.array([s for s, _ in TILE_RAMP])
    colours = np.array([c for _, c in TILE_RAMP], np.float64)
    rgb = np.stack([np.interp(t, stops, colours[:, k]) for k in range(3)], axis=-1)
    return np.rint(rgb).astype(np.uint8)


def display_image(view: str, values: np.ndarray) -> np.ndarray:
    """(H, W, 4) raw values of ``view`` -> (H, W, 3) uint8 display image (the table of the
    module docstring). Not for ``nan``, whose image app/render/debug.py makes."""
    rgb = np.asarray(values, np.float64)[..., :3]
    covered = np.asarray(values)[..., 3] > 0.0
    if view == "tiles":
        return tile_ramp(rgb[..., 0])
    if view in ("base_color", "f0", "fresnel"):
        out = to_bytes(srgb_encode(rgb))
    elif view in ("normal", "coat_normal"):
        out = to_bytes(rgb * 0.5 + 0.5)
    elif view in ("roughness", "metallic", "g2", "occlusion"):
        out = to_bytes(rgb)
    elif view == "depth":
        z = rgb[..., 0]
        lo, hi = (z[covered].min(), z[covered].max()) if covered.any() else (0.0, 1.0)
        t = (z - lo) / (hi - lo) if hi > lo else np.zeros_like(z)
        grey = 1.0 - (1.0 - DEPTH_FAR_GREY) * t  # near white, far dark grey
        out = to_bytes(np.repeat(grey[..., None], 3, axis=-1))
    elif view == "material_id":
        ids = np.nan_to_num(rgb[..., 0]).astype(np.int64)
        out = PALETTE[ids % len(PALETTE)]
    elif view in ("specular", "diffuse"):
        out = to_bytes(srgb_encode(compress(np.pi * rgb)))
    elif view == "ndf":
        with np.errstate(divide="ignore"):  # D = 0: log10 -inf, black
            out = to_bytes((np.log10(np.maximum(rgb, 0.0)) - NDF_LOG_MIN) / NDF_LOG_DECADES)
    elif view in ("light", "emission"):
        out = to_bytes(srgb_encode(compress(rgb)))
    else:
        raise ValueError(f"unknown debug view '{view}' (one of {', '.join(DEBUG_VIEWS)})")
    return np.where(covered[..., None], out, np.uint8(0)).astype(np.uint8)


class DebugPass:
    """The debug views of one rendered frame (``renderer.render()`` has run)."""

    def __init__(self, renderer: Renderer) -> None:
        self.renderer = renderer
        self.ctx = renderer.gl.ctx
        self.size = renderer.render_size
        self.target = self.ctx.texture(self.size, 4, dtype="f4")
        self.target.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = self.ctx.framebuffer([self.target])
        self.display: moderngl.Texture = self.ctx.texture(self.size, 4)  # RGBA8
        self.view: str | None = None
        self.bad_pixels: BadPixels | None = None  # the nan view's classification
        self._values: np.ndarray | None = None
        self._display: np.ndarray | None = None
        self._draws: dict[int, FullscreenDraw] = {}  # by id of a cached program
        # _tile_culler's own culler and the lighting pass it was made for (whose lights
        # and size it has); made again only when the renderer builds a new one
        self._own_culler: tuple[LightingPass, LightCuller] | None = None

    @property
    def tiled(self) -> bool:
        """Whether the tiles view has masks to show: the frame's (app/render/culling.py
        tiles_used), or under ``"auto"`` below its light count the ones ``"tiled"`` would
        cull (``_tile_culler``); none without local lights or with ``"none"``."""
        return self.renderer.culler is not None or self._auto_tiles()

    def _auto_tiles(self) -> bool:
        r = self.renderer
        return r.scene.render.light_culling == "auto" and tiles_used("tiled", r.lights)

    def _tile_culler(self) -> LightCuller | None:
        """The culler whose masks the tiles view shows: the frame's; or, where ``"auto"``
        drew the frame without tiles, one of this pass's own (kept while the renderer's
        lighting pass is the same), run now on the frame's G-buffer, so that the view
        shows what tiled culling gives the scene."""
        r = self.renderer
        if r.culler is not None or not self._auto_tiles():
            return r.culler
        if self._own_culler is None or self._own_culler[0] is not r.lighting:
            self._release_own_culler()
            culler = LightCuller(self.ctx, r.shaders, r.render_size, r.lights)
            self._own_culler = (r.lighting, culler)
        culler = self._own_culler[1]
        culler.run(r.gbuffer, r.view, r.camera)
        return culler

    def _release_own_culler(self) -> None:
        if self._own_culler is not None:
            self._own_culler[1].release()
            self._own_culler = None

    def _context(self, view: str) -> ShadingContext:
        """The shader inputs ``view`` reads: the tile masks (``_tile_culler``'s, none
        without tiles) for ``tiles``, else the frame's G-buffer, lights, material table
        and lookup tables (``SURFACE_ROLES``)."""
        if view == "tiles":
            culler = self._tile_culler()
            return ShadingContext([culler] if culler is not None else [])
        context = self.renderer.shading.only(*SURFACE_ROLES)
        context.require(f"the debug view {view!r}", GBUFFER, LIGHTS, MATERIALS)
        return context

    def _programs(self, view: str, context: ShadingContext) -> list[moderngl.Program]:
        """The view's programs from the renderer's shader cache, compiled with
        ``context``'s defines: one per model group for the BRDF views and f0
        (``MODEL_VIEWS``, as app/render/lighting.py builds them), one otherwise."""
        r = self.renderer
        defines: dict[str, int] = {"DEBUG_VIEW": DEBUG_VIEW_CODE[view], **context.defines()}
        if view == "tiles":
            variants = [defines]
        else:
            defines["BRDF_TERMS"] = BRDF_TERMS[r.scene.render.terms]
            models = r.materials.models
            if view in MODEL_VIEWS:
                variants = [
                    defines | model.defines() | ({"MODEL_GROUP": g} if len(models) > 1 else {})
                    for g, model in enumerate(models)
                ]
            else:
                variants = [defines]
        return [
            r.shaders.program("passes/fullscreen.vert", "passes/debug.frag", d) for d in variants
        ]

    def run(self, view: str, light: int = 0) -> None:
        """Evaluate ``view`` (a key of DEBUG_VIEWS); ``light`` indexes ``renderer.lights``
        for the BRDF views. Raises ValueError for an unknown view or light."""
        if view not in DEBUG_VIEWS:
            raise ValueError(f"unknown debug view '{view}' (one of {', '.join(DEBUG_VIEWS)})")
        r = self.renderer
        if view in LIGHT_VIEWS and not 0 <= light < len(r.lights):
            raise ValueError(f"light {light} out of range: the frame has {len(r.lights)} lights")
        self.view = view
        self.bad_pixels = None
        if view == "nan":
            hdr = r.read_hdr()
            self._values = np.concatenate([hdr, np.ones_like(hdr[..., :1])], axis=-1)
            self._display, self.bad_pixels = nan_debug_image(hdr, r.read_ldr())
        else:
            self._render(view, light)
            w, h = self.size
            wait_before_read(self.target.ctx)
            raw = np.frombuffer(self.target.read(), np.float32).reshape(h, w, 4)
            self._values = raw[::-1].copy()
            self._display = display_image(view, self._values)
        self._upload_display()

    def _render(self, view: str, light: int) -> None:
        context = self._context(view)
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        context.use()
        for prog in self._programs(view, context):
            context.bind(prog)  # a view reads only some of the inputs
            bind_camera(prog, self.renderer.camera)
            if id(prog) not in self._draws:  # the shader cache keeps the program alive
                self._draws[id(prog)] = FullscreenDraw(self.ctx, prog)
            self._draws[id(prog)].draw(self.fbo, {"u_light": light})

    def _upload_display(self) -> None:
        """The display image into ``display`` (RGBA8, rows bottom-up as GL stores them)."""
        image = self._display
        h, w = image.shape[:2]
        if self.display.size != (w, h):  # the nan view is at the output size
            self.display.release()
            self.display = self.ctx.texture((w, h), 4)
        rgba = np.concatenate([image, np.full((h, w, 1), 255, np.uint8)], axis=-1)
        self.display.write(np.ascontiguousarray(rgba[::-1]).tobytes())

    def read_values(self) -> np.ndarray:
        """The last view's raw values, (H, W, 4) float32, rows top to bottom."""
        if self._values is None:
            raise RuntimeError("DebugPass.run() has not run")
        return self._values

    def read_display(self) -> np.ndarray:
        """The last view's display image, (H, W, 3) uint8, rows top to bottom."""
        if self._display is None:
            raise RuntimeError("DebugPass.run() has not run")
        return self._display

    def release(self) -> None:
        release_objects(*self._draws.values(), self.fbo, self.target, self.display)
        self._release_own_culler()
