"""docs/stability.md's figure of the NaN debug view (``pbs render --debug nan``), rendered
from the present code.

``stress-nan-debug.png``: scenes/stress.toml at its own size (640x360) rendered as
``pbs render`` does, its HDR image completed, then values the renderer never writes put
into that very RGBA32F texture on the GPU (``write_bit_patterns``): four 14x14 blocks of
NaN, +Inf, -Inf and -0.5 left to right (``BLOCKS``, each in one channel) and two single
NaN pixels (``SPECKS``), which a reader of the image can hardly see, so the line printed
with it gives the first one's coordinates. The debug view (``DebugPass``, the CLI's
``--debug nan``) then paints the dimmed render and the bad pixels in their colours, and
the script prints its line of counts (the one docs/stability.md quotes). The PNG is
written with a palette (a dimmed grey and four colours: fewer than 256, so exact).

``python scripts/nan_debug_figure.py [OUT_DIR]`` writes it (default docs/images).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from PIL import Image

from app.gl.context import GLContext, create_context
from app.render.debug import (
    MINUS_HALF_BITS,
    NAN_BITS,
    NEG_INF_BITS,
    POS_INF_BITS,
    BadPixels,
    BitPatch,
    describe,
    write_bit_patterns,
)
from app.render.debug_views import DebugPass
from app.render.renderer import Renderer
from app.scene.loader import load_scene

# What the script writes, shown in docs/stability.md (tests/test_docs_images.py).
FIGURE = "stress-nan-debug.png"
SCENE = Path(__file__).resolve().parent.parent / "scenes" / "stress.toml"
BLOCK = 14  # pixels a side
# (bit pattern, channel, GL rectangle: x, y from the bottom, width, height): a block of each
# kind a quarter of the 640-pixel width apart, on the floor below the row of spheres
BLOCKS: tuple[BitPatch, ...] = tuple(
    (bits, channel, (70 + 160 * k, 60, BLOCK, BLOCK))
    for k, (bits, channel) in enumerate(
        [(NAN_BITS, 0), (POS_INF_BITS, 1), (NEG_INF_BITS, 2), (MINUS_HALF_BITS, 0)]
    )
)
# two single NaN pixels, at x = 300, y = 239 and x = 150, y = 264 counted from the top
SPECKS: tuple[BitPatch, ...] = ((NAN_BITS, 1, (300, 120, 1, 1)), (NAN_BITS, 2, (150, 95, 1, 1)))


def nan_debug_figure(gl: GLContext) -> tuple[np.ndarray, BadPixels]:
    """The stress scene's NaN debug view with ``BLOCKS`` and ``SPECKS`` written into its
    HDR target, (H, W, 3) uint8, and the bad pixels the view found."""
    renderer = Renderer(gl, load_scene(SCENE))
    try:
        renderer.render()
        renderer.read_hdr()  # a fused frame's HDR image drawn now, into the lighting pass's
        write_bit_patterns(gl.ctx, renderer.lighting.fbo, [*BLOCKS, *SPECKS])
        debug = DebugPass(renderer)
        try:
            debug.run("nan")
            image, bad = debug.read_display(), debug.bad_pixels
        finally:
            debug.release()
    finally:
        renderer.release()
    assert bad is not None
    return image, bad


def palette_png(image: np.ndarray) -> Image.Image:
    """``image`` (H, W, 3) uint8 as a palette PNG's image, exact: its distinct colours
    (fewer than 257) as the palette."""
    colours, index = np.unique(image.reshape(-1, 3), axis=0, return_inverse=True)
    if len(colours) > 256:
        raise ValueError(f"{len(colours)} colours: more than a palette holds")
    out = Image.fromarray(index.reshape(image.shape[:2]).astype(np.uint8), mode="P")
    out.putpalette(colours.astype(np.uint8).ravel().tolist())
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    start = time.perf_counter()
    gl = create_context("auto")
    try:
        image, bad = nan_debug_figure(gl)
    finally:
        gl.release()
    path = args.out / FIGURE
    palette_png(image).save(path, optimize=True)
    h, w = image.shape[:2]
    print(f"{path}: NaN debug view: {describe(bad)} of {w * h} pixels")
    print(f"{path}: {w}x{h}, {path.stat().st_size} bytes")
    took = time.perf_counter() - start
    print(f"{took:.0f} s, 1-minute load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
