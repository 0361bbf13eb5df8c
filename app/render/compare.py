"""Split-screen comparison: one scene rendered with two settings of one key, side by side.

The teaching tool of a classroom walkthrough: a material's ``fresnel = "schlick"`` against
``"conductor"`` (RTR4 §9.5), two ``g2`` forms (§9.7), ``render.normal_filter = "naive"``
against ``"variance"`` (§9.13), ``multiscatter`` off and on (§9.8). A ``CompareSpec`` names
the key as a scene file writes it and its two values; ``Comparison`` renders the two
sides with two ``Renderer``s (one ``ShaderCache``: a program both sides use is compiled
once) and composites them on the GPU (glsl/passes/compare.frag):

- ``"split"``: column x (0-based from the left) shows side A where
  ``x < divider_column(divider, W)``, side B from there on, with a divider line
  ``DIVIDER_WIDTH`` = 2 columns wide in ``DIVIDER_COLOR`` over the two columns either side
  of that boundary (``divider_line``); every other pixel is the side's own display image,
  bit for bit.
- ``"difference"``: ``|A - B|`` of the linear HDR radiance (each side times its own
  2^EV), times ``gain``, then side A's tone map and the sRGB encoding of the post pass:
  equal images give black.

    from app.gl.context import create_context
    from app.render.compare import Comparison, CompareSpec
    from app.scene.loader import load_scene

    c = Comparison(create_context(), load_scene("scenes/sec5_metals.toml"),
                   CompareSpec("materials.gold-schlick.fresnel", "schlick", "conductor"))
    c.render(); c.composite("split", divider=0.79); image = c.read_ldr()

The command line's form is ``--compare KEY=A,B`` (``parse_compare``, docs/compare.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import moderngl
import numpy as np

from app.common.tonemaps import TONEMAP_CODE
from app.errors import InputError
from app.gl.context import GLContext
from app.gl.shaders import ShaderCache
from app.render.fullscreen import FullscreenPass
from app.render.renderer import Renderer, RenderOptions
from app.scene.edits import KeyPathError, edited, parse_key, toml_value
from app.scene.loader import LoadedScene
from app.scene.model import Camera, Scene
from app.untrusted import RefusedError
from app.untrusted.policy import Limits
from app.untrusted.structured import parse_toml

Side = Literal["a", "b"]
Mode = Literal["split", "difference"]
MODES: tuple[Mode, ...] = ("split", "difference")

# The divider line of a split: this many columns, centred on the boundary between the
# halves, in this 8-bit sRGB colour: magenta, a hue no bundled scene's metals, white
# highlights or dark backgrounds hide (an amber line vanished against gold).
DIVIDER_WIDTH = 2
DIVIDER_COLOR = (255, 0, 255)

_VALUES_SYNTAX = (
    "expected KEY=A,B with A and B TOML values: strings in double quotes, numbers, true "
    'or false, [arrays] (materials.gold.fresnel="schlick","conductor")'
)


@dataclass(frozen=True)
class CompareSpec:
    """One key of the scene and its value on each side.

    ``key`` is a dotted path into the scene data as a scene file writes it
    (``materials.gold.fresnel``, ``render.normal_filter``, ``lights[0].intensity``,
    ``camera.aperture``); ``a`` and ``b`` are values as TOML reads them (str, int, float,
    bool, list, dict). ``origin`` names where the spec came from in error messages (the
    CLI's ``--compare``).
    """

    key: str
    a: object
    b: object
    origin: str = "comparison"
    path: tuple[str | int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", parse_key(self.key, self.origin))

    def value(self, side: Side) -> object:
        """The key's value on ``side`` ("a" or "b")."""
        if side not in ("a", "b"):
            raise ValueError(f"side must be 'a' or 'b', not {side!r}")
        return self.a if side == "a" else self.b

    def scene_for(self, base: LoadedScene, side: Side) -> LoadedScene:
        """``base`` with the key set to the side's value, validated as a scene file is
        (``parse_scene``): a refused value is the ``InputError`` the CLI prints, naming
        the key (and the side, and ``origin``).

        Every table and list on the way to the key must exist in ``base`` (a typo in a
        material's name must not quietly add a material that nothing uses); the last
        name may be a key the scene leaves at its default.
        """
        value = self.value(side)
        try:
            return edited(base, [(self.path, value)], self.origin)
        except KeyPathError:  # a step of the key is missing: the same for both sides
            raise
        except InputError as exc:
            why = f"{self.origin} side {side.upper()}: {self.key} = {toml_value(value)}"
            raise InputError(exc.file, exc.key, f"{exc.message} ({why})") from None

    def scenes(
        self, base: LoadedScene, size: tuple[int, int] | None = None
    ) -> tuple[LoadedScene, LoadedScene]:
        """Both sides' scenes, validated, and checked to render at one size (``size``
        overrides the scenes' render.width and render.height, as for ``Renderer``)."""
        a, b = self.scene_for(base, "a"), self.scene_for(base, "b")
        if size is None:
            sizes = [(s.scene.render.width, s.scene.render.height) for s in (a, b)]
            if sizes[0] != sizes[1]:
                (wa, ha), (wb, hb) = sizes
                raise InputError(
                    str(base.path),
                    self.key,
                    f"the sides render at different sizes ({wa}x{ha} and {wb}x{hb}); a "
                    f"comparison needs one ({self.origin})",
                )
        return a, b

    def describe(self) -> str:
        """``'materials.gold.fresnel: A = "schlick", B = "conductor"'``."""
        return f"{self.key}: A = {toml_value(self.a)}, B = {toml_value(self.b)}"

    def touches(self, table: str) -> bool:
        """Whether the key lies in the scene's top-level ``table`` (``"camera"``)."""
        return self.path[0] == table


def parse_compare(text: str, origin: str = "--compare") -> CompareSpec:
    """The command line's ``KEY=A,B``: the key path, ``=``, then two TOML values read as
    the TOML array ``[A,B]`` (strings in double quotes: ``"schlick","conductor"``;
    ``0.1,0.6``; ``true,false``; ``[1,0,0],[0,0,1]``). Anything else is an ``InputError``
    from ``origin`` naming the key."""
    in_quotes, split = False, -1
    for i, char in enumerate(text):
        if char == '"':
            in_quotes = not in_quotes
        elif char == "=" and not in_quotes:
            split = i
            break
    if split < 0:
        raise InputError(origin, "", f"{_VALUES_SYNTAX} (got {text!r})")
    key, values = text[:split].strip(), text[split + 1 :].strip()
    parse_key(key, origin)
    if "\n" in values or "\r" in values:
        raise InputError(origin, key, "the values must be on one line")
    try:
        data = parse_toml(f"values = [{values}]", Limits().max_nesting)
    except RefusedError:
        raise InputError(origin, key, f"{_VALUES_SYNTAX} (got {values!r})") from None
    if set(data) != {"values"} or len(data["values"]) != 2:
        raise InputError(origin, key, f"{_VALUES_SYNTAX}: two values (got {values!r})")
    a, b = data["values"]
    return CompareSpec(key, a, b, origin)


def divider_column(divider: float, width: int) -> int:
    """The first column of side B: ``round(divider * width)``, halves rounded up."""
    return min(max(math.floor(divider * width + 0.5), 0), width)


def divider_line(divider: float, width: int) -> range:
    """The columns the divider line covers: the ``DIVIDER_WIDTH`` columns centred on the
    boundary (the last of side A and the first of side B), clipped to the image. Columns
    before it show side A, columns after it side B."""
    column = divider_column(divider, width)
    half = DIVIDER_WIDTH // 2
    return range(max(column - half, 0), min(column + DIVIDER_WIDTH - half, width))


class ComparePass(FullscreenPass):
    """The composite of glsl/passes/compare.frag into an RGBA8 display image: the split
    (the sides' display images and the divider line) or the magnified difference (their
    HDR radiance, tone-mapped with ``tonemap``)."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        mode: Mode,
        tonemap: str,
    ) -> None:
        defines: dict[str, object] = {}
        if mode == "difference":
            defines = {"COMPARE_DIFFERENCE": 1, "TONEMAP": TONEMAP_CODE[tonemap]}
        super().__init__(ctx, shaders, "passes/compare.frag", defines, size, dtype="f1")
        self.mode = mode
        self.tonemap = tonemap

    def run_split(self, a: moderngl.Texture, b: moderngl.Texture, divider: float) -> None:
        """Side A's display image left of the divider, B's right of it, and the line."""
        width = self.size[0]
        line = divider_line(divider, width)
        self.draw(
            {
                "u_divider": divider_column(divider, width),
                "u_line": (line.start, line.stop),
                "u_line_color": tuple(c / 255.0 for c in DIVIDER_COLOR),
            },
            {"u_ldr_a": a, "u_ldr_b": b},
        )

    def run_difference(
        self,
        a: moderngl.Texture,
        b: moderngl.Texture,
        exposures_ev: tuple[float, float],
        gain: float,
    ) -> None:
        """``|2^EV_A A - 2^EV_B B| * gain``, tone-mapped and sRGB-encoded."""
        self.draw(
            {"u_exposure": tuple(2.0**ev for ev in exposures_ev), "u_gain": gain},
            {"u_hdr_a": a, "u_hdr_b": b},
        )


class Comparison:
    """Two renderers of one base scene that differ in ``spec``'s key, kept in step.

    ``render()`` renders both sides; ``composite(mode, divider, gain)`` makes the display
    image (``read_ldr``); ``set_camera`` and ``update_base`` change the base scene of both
    sides at once (the spec's value stays applied), as the viewer does every frame.
    ``size`` overrides the scenes' render.width and render.height; ``options`` are both
    sides' ``RenderOptions`` (the viewer's: its main view's, so that a side draws what the
    main view would, ``render.gbaa_interior`` left out of its interactive frames).
    """

    def __init__(
        self,
        gl: GLContext,
        base: LoadedScene,
        spec: CompareSpec,
        size: tuple[int, int] | None = None,
        options: RenderOptions | None = None,
    ) -> None:
        self.gl = gl
        self.spec = spec
        self.base = base
        self._size = size
        sides = spec.scenes(base, size)  # both validated before any GPU object exists
        # One cache: a program both sides need (every program, when the key is a
        # light's intensity) is compiled once. The cache outlives both renderers.
        self.shaders = ShaderCache(gl.ctx)
        self.renderers: list[Renderer] = []
        try:
            for side in sides:
                self.renderers.append(
                    Renderer(gl, side, size, shaders=self.shaders, options=options)
                )
        except BaseException:
            self.release()
            raise
        self._passes: dict[str, ComparePass] = {}
        self._last: ComparePass | None = None

    @property
    def size(self) -> tuple[int, int]:
        """The image's (width, height), the same on both sides."""
        return self.renderers[0].size

    @property
    def scenes(self) -> tuple[Scene, Scene]:
        """The scenes the two sides render now."""
        return self.renderers[0].scene, self.renderers[1].scene

    # --- keeping both sides in step --------------------------------------------------------

    def set_camera(self, camera: Camera) -> None:
        """A new camera for the base scene, on both sides. Where the compared key is the
        camera's (``camera.aperture``), each side keeps its own value of it."""
        base = self.base.with_scene(self.base.scene.model_copy(update={"camera": camera}))
        if self.spec.touches("camera"):
            sides = self.spec.scenes(base, self._size)
            cameras = [side.scene.camera for side in sides]
        else:
            cameras = [camera, camera]
        for renderer, side_camera in zip(self.renderers, cameras, strict=True):
            renderer.set_camera(side_camera)
        self.base = base

    def update_base(self, scene: Scene | LoadedScene) -> None:
        """Show an edit of the base scene on both sides (``Renderer.update`` on each, with
        the spec's values applied). Both sides are validated first: a refused edit raises
        ``InputError`` and changes nothing."""
        base = scene if isinstance(scene, LoadedScene) else self.base.with_scene(scene)
        sides = self.spec.scenes(base, self._size)
        for renderer, side in zip(self.renderers, sides, strict=True):
            renderer.update(side.scene)
        self.base = base

    def resize(self, size: tuple[int, int]) -> None:
        """Both sides at a new image size (the viewer's window, or its preview)."""
        self._size = (int(size[0]), int(size[1]))
        for renderer in self.renderers:
            renderer.resize(self._size)

    # --- the frame --------------------------------------------------------------------------

    def render(self) -> None:
        """Render both sides; the images stay on the GPU until composited or read."""
        for renderer in self.renderers:
            renderer.render()

    def composite(
        self, mode: Mode = "split", divider: float = 0.5, gain: float = 8.0
    ) -> moderngl.Texture:
        """Composite the last rendered sides into the RGBA8 display texture (returned, and
        read by ``read_ldr``). ``divider``: where the split falls, a fraction of the
        width in [0, 1]; ``gain``: the difference's magnification, > 0."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
        if not 0.0 <= divider <= 1.0:  # also refuses NaN
            raise ValueError(f"divider must lie in [0, 1], not {divider!r}")
        if not (0.0 < gain < math.inf):
            raise ValueError(f"gain must be a finite number > 0, not {gain!r}")
        a, b = self.renderers
        tonemap = a.scene.render.tonemap
        current = self._passes.get(mode)
        if current is None or current.size != self.size or current.tonemap != tonemap:
            if current is not None:
                current.release()
            current = ComparePass(self.gl.ctx, self.shaders, self.size, mode, tonemap)
            self._passes[mode] = current
        for renderer in self.renderers:  # the next frames draw what this mode reads
            renderer.want_hdr(mode != "split")
        if mode == "split":
            current.run_split(a.display_texture, b.display_texture, divider)
        else:
            exposures = (a.scene.camera.exposure, b.scene.camera.exposure)
            current.run_difference(a.hdr_texture, b.hdr_texture, exposures, gain)
        self._last = current
        return current.target

    @property
    def last_target(self) -> moderngl.Texture | None:
        """The RGBA8 texture of the last composite (None before the first)."""
        return None if self._last is None else self._last.target

    def read_ldr(self) -> np.ndarray:
        """The last composite, (H, W, 3) uint8 sRGB, rows top to bottom."""
        if self._last is None:
            raise RuntimeError("nothing composited yet: call render() and composite()")
        return self._last.read()

    def read_sides(self) -> tuple[np.ndarray, np.ndarray]:
        """Both sides' linear HDR radiance, (H, W, 3) float32 each (``Renderer.read_hdr``)."""
        return self.renderers[0].read_hdr(), self.renderers[1].read_hdr()

    def release(self) -> None:
        """Release the renderers and passes, then the cache they share."""
        for renderer in self.renderers:
            renderer.release()
        self.renderers = []
        for compare_pass in getattr(self, "_passes", {}).values():
            compare_pass.release()
        self._passes = {}
        self._last = None
        self.shaders.release()
