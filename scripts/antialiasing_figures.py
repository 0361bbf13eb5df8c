"""docs/antialiasing.md's two figures, rendered from the present code.

``antialiasing-modes.png``: every ``render.antialiasing`` mode on scenes/showcase.toml
(lit by the studio) at 640x360, one crop (a red sphere's top over two metal spheres and
the floor) enlarged 4x with nearest-neighbour so that each pixel is a visible square,
beside the 4x4 supersampled frame (the box-filtered reference) and the whole frame with
the crop marked.

``antialiasing-gbaa.png``: what gbaa does at silhouettes, on the antialiasing bench's
spheres (app/bench/antialiasing.py) at 320x180, three crops enlarged 6x: the aliased
frame, gbaa and the 4x4 box, then the coverage gbaa computes (the alpha of a transparent
background) beside the 4x4 samples' coverage.

``python scripts/antialiasing_figures.py [OUT_DIR]`` writes both (default docs/images).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from app.bench.antialiasing import aa_scene_data, with_aa
from app.gl.context import GLContext, create_context
from app.render.renderer import Renderer
from app.scene.edits import replace_parts
from app.scene.loader import LoadedScene
from app.scene.sources import scene_from
from app.walkthrough.labels import caption_band, find_font

# What the script writes, each shown in docs/antialiasing.md (tests/test_docs_images.py).
MODES_FIGURE = "antialiasing-modes.png"
GBAA_FIGURE = "antialiasing-gbaa.png"
JITTER_SAMPLES = 8
GUTTER = 4  # pixels between panels
GUTTER_RGB = (255, 255, 255)
GREY_RGB = (128, 128, 128)  # the gbaa figure's gutters: neither covered (white) nor empty
LABEL_SIZE = 17  # label text height, pixels
MARK_RGB = (255, 220, 0)  # the crop's outline on the whole frame

# The modes figure: (label, render.antialiasing, render.supersample), in the order shown.
SHOWCASE_SIZE = (640, 360)
SHOWCASE_MODES: tuple[tuple[str, str, int], ...] = (
    ("none (one sample a pixel)", "none", 1),
    ("fxaa", "fxaa", 1),
    (f"jitter, {JITTER_SAMPLES} samples", "jitter", 1),
    ("sraa", "sraa", 1),
    ("gbaa (the default)", "gbaa", 1),
    ("msaa", "msaa", 1),
    ("4×4 supersampled (reference)", "none", 4),
)
SHOWCASE_CROP = (36, 142, 80, 45)  # x, y (from the top), width, height at SHOWCASE_SIZE
SHOWCASE_ZOOM = 4
COLUMNS = 4

# The gbaa figure: the bench's spheres, three silhouettes (x, y, width, height).
SPHERES_SIZE = (320, 180)
SPHERES_CROPS: tuple[tuple[int, int, int, int], ...] = (
    (173, 68, 36, 14),  # the red sphere's top
    (262, 66, 36, 14),  # the icosphere's upper right edge
    (20, 56, 36, 14),  # the white sphere's upper left rim, near 45 degrees
)
SPHERES_ZOOM = 6
PAIR = ("none", "gbaa")  # the frames whose crops are measured against the 4x4 box


def _with_render(loaded: LoadedScene, **update: object) -> LoadedScene:
    """``loaded`` with the ``[render]`` keys in ``update`` set (the background here)."""
    render = loaded.scene.render.model_copy(update=update)
    return dataclasses.replace(loaded, scene=replace_parts(loaded.scene, render=render))


def draw(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int], mode: str, supersample: int = 1
) -> np.ndarray:
    """The display image (rows top first) with its alpha, (H, W, 4) uint8, of ``loaded``
    drawn in ``mode`` (checked to be the mode the renderer draws, no fallback)."""
    specular_aa = loaded.scene.render.specular_aa
    r = Renderer(gl, with_aa(loaded, mode, JITTER_SAMPLES, supersample, specular_aa), size)
    try:
        if r.antialiasing != mode:
            raise RuntimeError(f"the renderer draws {r.antialiasing!r}, not {mode!r}")
        r.render()
        return r.read_rgba()
    finally:
        r.release()


def enlarged(image: np.ndarray, crop: tuple[int, int, int, int], zoom: int) -> np.ndarray:
    """The ``crop`` (x, y, width, height) of ``image``, each pixel a ``zoom`` square."""
    x, y, w, h = crop
    part = image[y : y + h, x : x + w]
    return np.repeat(np.repeat(part, zoom, axis=0), zoom, axis=1)


def grid(
    panels: list[np.ndarray], columns: int, gutter: tuple[int, int, int] = GUTTER_RGB
) -> np.ndarray:
    """``panels`` (RGB, one width) laid out ``columns`` a row, top-aligned, with
    ``gutter``-coloured gaps between them."""
    width = panels[0].shape[1]
    rows = [panels[k : k + columns] for k in range(0, len(panels), columns)]
    heights = [max(p.shape[0] for p in row) for row in rows]
    sheet = np.full(
        (sum(heights) + GUTTER * (len(rows) - 1), columns * (width + GUTTER) - GUTTER, 3),
        gutter,
        np.uint8,
    )
    top = 0
    for row, height in zip(rows, heights, strict=True):
        for k, panel in enumerate(row):
            left = k * (width + GUTTER)
            sheet[top : top + panel.shape[0], left : left + width] = panel
        top += height + GUTTER
    return sheet


def column(tiles: list[np.ndarray], gutter: tuple[int, int, int] = GUTTER_RGB) -> np.ndarray:
    """``tiles`` (one width) stacked with ``gutter``-coloured gaps between them."""
    width = tiles[0].shape[1]
    gap = np.full((GUTTER, width, 3), gutter, np.uint8)
    parts: list[np.ndarray] = []
    for tile in tiles:
        parts += [gap, tile] if parts else [tile]
    return np.concatenate(parts, axis=0)


def modes_figure(gl: GLContext) -> np.ndarray:
    """The modes figure (see the module's docstring)."""
    face = find_font("en")
    loaded = scene_from("showcase", size=SHOWCASE_SIZE)
    panels = []
    reference = None
    for label, mode, supersample in SHOWCASE_MODES:
        image = draw(gl, loaded, SHOWCASE_SIZE, mode, supersample)[..., :3]
        if supersample > 1:
            reference = image
        crop = enlarged(image, SHOWCASE_CROP, SHOWCASE_ZOOM)
        panels.append(caption_band(crop, label, face, LABEL_SIZE, where="bottom"))
    assert reference is not None
    # the whole reference frame, scaled to a panel's width, the crop outlined
    w, h = SHOWCASE_CROP[2] * SHOWCASE_ZOOM, SHOWCASE_CROP[3] * SHOWCASE_ZOOM
    scale = w / SHOWCASE_SIZE[0]
    whole = Image.fromarray(reference).resize((w, round(SHOWCASE_SIZE[1] * scale)), Image.BOX)
    x, y, cw, ch = (round(v * scale) for v in SHOWCASE_CROP)
    ImageDraw.Draw(whole).rectangle((x - 1, y - 1, x + cw, y + ch), outline=MARK_RGB, width=2)
    overview = np.zeros((h, w, 3), np.uint8)
    overview[: whole.height] = np.asarray(whole)
    label = "the whole frame, the crop marked"
    panels.append(caption_band(overview, label, face, LABEL_SIZE, where="bottom"))
    return grid(panels, COLUMNS)


def coverage(alpha: np.ndarray) -> np.ndarray:
    """A coverage (uint8 alpha) as a grey RGB image."""
    return np.repeat(alpha[..., None], 3, axis=2)


def gbaa_figure(gl: GLContext) -> tuple[np.ndarray, str]:
    """The gbaa figure (see the module's docstring), and lines of what it shows: the mean
    |coverage - 4x4 coverage| of the aliased frame and of gbaa over the whole image's
    silhouette pixels (where the 4x4 coverage is fractional), and each crop's mean
    |display - 4x4 display| of both."""
    face = find_font("en")
    loaded = scene_from(aa_scene_data(SPHERES_SIZE))
    clear = _with_render(loaded, background="transparent")
    images = {
        "none": draw(gl, loaded, SPHERES_SIZE, "none")[..., :3],
        "gbaa": draw(gl, loaded, SPHERES_SIZE, "gbaa")[..., :3],
        "4×4 box": draw(gl, loaded, SPHERES_SIZE, "none", 4)[..., :3],
    }
    alphas = {
        "gbaa's coverage": draw(gl, clear, SPHERES_SIZE, "gbaa")[..., 3],
        "4×4 coverage": draw(gl, clear, SPHERES_SIZE, "none", 4)[..., 3],
    }
    truth = alphas["4×4 coverage"].astype(np.float64) / 255.0
    edge = (truth > 0.0) & (truth < 1.0)
    aliased = draw(gl, clear, SPHERES_SIZE, "none")[..., 3].astype(np.float64) / 255.0
    resolved = alphas["gbaa's coverage"].astype(np.float64) / 255.0
    off = [float(np.abs(a - truth)[edge].mean()) for a in (aliased, resolved)]
    lines = [
        f"coverage at {int(edge.sum())} silhouette pixels, mean |a - 4x4|: none {off[0]:.4f},"
        f" gbaa {off[1]:.4f} ({off[0] / off[1]:.1f}x closer)"
    ]
    box = images["4×4 box"].astype(np.float64)
    for x, y, w, h in SPHERES_CROPS:
        crop = (slice(y, y + h), slice(x, x + w))
        means = {k: np.abs(images[k].astype(np.float64) - box)[crop].mean() for k in PAIR}
        ranked = ", ".join(f"{k} {v:.2f}" for k, v in means.items())
        lines.append(f"crop {x},{y} {w}x{h}: mean |display - 4x4| in 8-bit steps: {ranked}")
    note = "\n".join(lines)
    panels = []
    for label, image in images.items():
        tiles = [enlarged(image, crop, SPHERES_ZOOM) for crop in SPHERES_CROPS]
        stacked = column(tiles, GREY_RGB)
        panels.append(caption_band(stacked, label, face, LABEL_SIZE, where="bottom"))
    for label, alpha in alphas.items():
        tiles = [enlarged(coverage(alpha), crop, SPHERES_ZOOM) for crop in SPHERES_CROPS]
        stacked = column(tiles, GREY_RGB)
        panels.append(caption_band(stacked, label, face, LABEL_SIZE, where="bottom"))
    return grid(panels, len(panels), GREY_RGB), note


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    gl = create_context("auto")
    start = time.perf_counter()
    try:
        modes = modes_figure(gl)
        gbaa, note = gbaa_figure(gl)
    finally:
        gl.release()
    figures = {MODES_FIGURE: modes, GBAA_FIGURE: gbaa}
    for name, figure in figures.items():
        path = args.out / name
        Image.fromarray(figure).save(path, optimize=True)
        print(f"{path}: {figure.shape[1]}x{figure.shape[0]}, {path.stat().st_size} bytes")
    print(note)
    took = time.perf_counter() - start
    print(f"{took:.0f} s, 1-minute load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
