"""The NaN/Inf debug view of ``pbs render --debug nan``.

Every pixel whose linear HDR radiance (the lighting pass's RGBA32F target, before
exposure) is not a finite number >= 0 is painted in a loud colour over a dimmed
greyscale of the normal render, one colour per kind:

=============  ==============  =====================================================
kind           colour          a pixel is of this kind when any of its R, G, B ...
=============  ==============  =====================================================
``nan``        magenta         is NaN
``+inf``       yellow          is +Inf (and none is NaN)
``-inf``       cyan            is -Inf (and none is NaN or +Inf)
``negative``   green           is finite and < 0 (and none is NaN or +-Inf)
=============  ==============  =====================================================

Each pixel counts once, under the first kind in that order, so the counts add up to the
number of painted pixels. -0.0 is not negative (it compares equal to 0).

The classification runs in numpy on the HDR image read back to the CPU, not in a GLSL
pass: it must be exact, and GLSL does not promise that ``isnan`` sees a NaN (the GLSL ES
reference page of ``isnan``: an implementation may not support NaNs, and then ``isnan``
returns false). numpy classifies the very float32 bits the GPU stored, and the counts
come from the same array as the image. The cost is one read-back of the HDR target
(16 bytes a pixel) and a few array operations.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import moderngl
import numpy as np

from app.gl.fullscreen import FullscreenDraw

# The kinds in the order of precedence, with their colours (8-bit sRGB).
KIND_COLORS: dict[str, tuple[int, int, int]] = {
    "nan": (255, 0, 255),  # magenta
    "+inf": (255, 255, 0),  # yellow
    "-inf": (0, 255, 255),  # cyan
    "negative": (0, 255, 0),  # green
}
KIND_COLOR_NAMES = {"nan": "magenta", "+inf": "yellow", "-inf": "cyan", "negative": "green"}

# The normal render is shown as grey at this fraction of its luminance, so that the
# loud colours (all with a channel at 255) stand out even over white.
DIM = 0.35


@dataclass(frozen=True)
class BadPixels:
    """Where the HDR image is not finite and >= 0: one exclusive mask per kind."""

    masks: dict[str, np.ndarray]  # kind -> (H, W) bool, in KIND_COLORS order

    @property
    def counts(self) -> dict[str, int]:
        return {kind: int(mask.sum()) for kind, mask in self.masks.items()}

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def first(self, kind: str) -> tuple[int, int] | None:
        """(x, y) of the first pixel of ``kind`` in reading order (y down), or None."""
        ys, xs = np.nonzero(self.masks[kind])
        return (int(xs[0]), int(ys[0])) if len(xs) else None


def classify(hdr: np.ndarray) -> BadPixels:
    """The bad pixels of an (H, W, C) HDR image, by kind (see the module docstring)."""
    rgb = np.asarray(hdr)[..., :3]
    nan = np.isnan(rgb).any(axis=-1)
    pos_inf = np.isposinf(rgb).any(axis=-1) & ~nan
    neg_inf = np.isneginf(rgb).any(axis=-1) & ~nan & ~pos_inf
    with np.errstate(invalid="ignore"):  # NaN < 0 is False, as wanted
        negative = (rgb < 0.0).any(axis=-1) & ~nan & ~pos_inf & ~neg_inf
    return BadPixels({"nan": nan, "+inf": pos_inf, "-inf": neg_inf, "negative": negative})


def dimmed_grey(ldr: np.ndarray, dim: float = DIM) -> np.ndarray:
    """(H, W, 3) uint8 display image -> its luminance (Rec. 709 weights on the encoded
    values, good enough for a backdrop) as grey, scaled by ``dim``."""
    rgb = np.asarray(ldr, np.float64)
    grey = (rgb @ np.array([0.2126, 0.7152, 0.0722])) * dim
    return np.repeat(np.clip(np.rint(grey), 0, 255).astype(np.uint8)[..., None], 3, axis=-1)


def nan_debug_image(hdr: np.ndarray, ldr: np.ndarray) -> tuple[np.ndarray, BadPixels]:
    """The debug view: dimmed grey ``ldr`` with the bad pixels of ``hdr`` in their colours.

    ``hdr`` is (H, W, 3) float32 linear radiance, ``ldr`` the (H, W, 3) uint8 display
    image of the same frame (both rows top to bottom, as the Renderer reads them).
    """
    if hdr.shape[:2] != ldr.shape[:2]:
        raise ValueError(f"HDR {hdr.shape[:2]} and LDR {ldr.shape[:2]} sizes differ")
    bad = classify(hdr)
    image = dimmed_grey(ldr)
    for kind, mask in bad.masks.items():
        image[mask] = KIND_COLORS[kind]
    return image, bad


def describe(bad: BadPixels) -> str:
    """One line of counts, e.g. 'NaN 0 (magenta), +Inf 0 (yellow), ...', with the first
    pixel of each kind that occurs."""
    labels = {"nan": "NaN", "+inf": "+Inf", "-inf": "-Inf", "negative": "negative"}
    parts = []
    for kind, count in bad.counts.items():
        text = f"{labels[kind]} {count} ({KIND_COLOR_NAMES[kind]})"
        first = bad.first(kind)
        if first is not None:
            text += f" first at x={first[0]} y={first[1]}"
        parts.append(text)
    return ", ".join(parts)


# Float32 bit patterns of the values the debug view finds (and -0.0, which it does not).
NAN_BITS, POS_INF_BITS, NEG_INF_BITS = 0x7FC00000, 0x7F800000, 0xFF800000
MINUS_HALF_BITS, MINUS_ZERO_BITS = 0xBF000000, 0x80000000

_WRITE_VERTEX = """#version 330 core
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
_WRITE_FRAGMENT = """#version 330 core
uniform uint u_bits;    // a float32 bit pattern, written into channel u_channel
uniform int u_channel;
out vec4 frag_color;
void main() {
    vec3 c = vec3(0.25);
    c[u_channel] = uintBitsToFloat(u_bits);
    frag_color = vec4(c, 1.0);
}
"""

# A rectangle of a float target to overwrite: (float32 bit pattern, channel, GL rectangle
# (x, y from the bottom, width, height)); the other two channels get 0.25, alpha 1.
BitPatch = tuple[int, int, tuple[int, int, int, int]]


def write_bit_patterns(
    ctx: moderngl.Context, fbo: moderngl.Framebuffer, patches: Iterable[BitPatch]
) -> None:
    """Overwrite rectangles of ``fbo``'s float colour target with exact float32 bit
    patterns (NaN, +-Inf, negatives), drawn on the GPU into the very texture the frame
    was drawn into: what the debug view is checked and shown with (its tests, the
    figure of docs/stability.md), since the renderer itself writes no such value. A
    bit pattern, not a float uniform: a NaN must reach the target as stored bits."""
    draw = FullscreenDraw(
        ctx,
        ctx.program(vertex_shader=_WRITE_VERTEX, fragment_shader=_WRITE_FRAGMENT),
        owns_program=True,
    )
    try:
        for bits, channel, rect in patches:
            fbo.scissor = rect
            draw.draw(fbo, {"u_bits": bits, "u_channel": channel})
        fbo.scissor = None
        fbo.use()
    finally:
        draw.release()
