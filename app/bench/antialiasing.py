"""Suite ``antialiasing``: each ``render.antialiasing`` candidate's frame time against its
error, taken over every pixel of the display image, against the same renderer's 4x4 and
8x8 supersampled frames (docs/antialiasing.md).

The scene: four spheres (three analytic, one icosphere of 3 subdivisions: a polygonal
silhouette) on a dark background, one of them a smooth metal under a point light, whose
highlight covers under a pixel. Each candidate's display image (sRGB, 0..1) is compared
with the supersampled frames' in three masks: every pixel, the silhouette pixels (those
whose 4x4 block of G-buffer samples holds more than one surface or the background:
geometric aliasing), and the highlight pixels (the smooth sphere's interior pixels where
the 8x8 frame is bright, and two pixels around: specular aliasing). The times are one
``render()`` each, timed in alternating rounds with the aliased frame ("none"); each
row holds the median over the rounds of its frame's time over "none"'s in that round.
The "+specular_aa" rows add ``render.specular_aa`` (the highlight's question); the
time-vs-error front is over the antialiasing modes alone.

"jitter-display:N" is not a renderer mode: the mean of the display images of N jittered
samples (each tone-mapped, then averaged), computed here to answer which order matches
the supersampled frame (the resolve averages radiance, then tone-maps); it has no time.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.bench.context import Context, Settings, make_row
from app.bench.timing import Budget, Pass
from app.render.renderer import Renderer, RenderOptions
from app.scene.edits import replace_parts
from app.scene.loader import LoadedScene
from app.scene.sources import scene_from

SUITE = "antialiasing"
# The candidates: (variant name, render.antialiasing, antialiasing_samples, specular_aa).
CANDIDATES: tuple[tuple[str, str, int, bool], ...] = (
    ("none", "none", 8, False),
    ("fxaa", "fxaa", 8, False),
    ("jitter:2", "jitter", 2, False),
    ("jitter:4", "jitter", 4, False),
    ("jitter:8", "jitter", 8, False),
    ("jitter:16", "jitter", 16, False),
    ("sraa", "sraa", 8, False),
    ("gbaa", "gbaa", 8, False),
    ("msaa", "msaa", 8, False),
    ("none+specular_aa", "none", 8, True),
    ("fxaa+specular_aa", "fxaa", 8, True),
)
DISPLAY_MEAN_SAMPLES = 8  # "jitter-display:N"'s N
HIGHLIGHT_LEVEL = 0.5  # display value (max of RGB) above which a pixel is in the highlight
SMOOTH = 1  # the scene's object with the smooth metal (roughness 0.05)


def _sphere(radius: float, position: list[float], material: str) -> dict:
    return {"shape": "sphere", "radius": radius, "position": position, "material": material}


def aa_scene_data(size: tuple[int, int]) -> dict:
    """The suite's scene (see the module's docstring) at ``size``."""
    return {
        "background": [0.02, 0.02, 0.03],
        "render": {"width": size[0], "height": size[1]},
        "camera": {"position": [0.0, 0.8, 6.0], "target": [0.0, 0.0, 0.0], "fov_y": 32.0},
        "materials": {
            "white": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6},
            "chrome": {"base_color": [0.95, 0.93, 0.88], "metallic": 1.0, "roughness": 0.05},
            "red": {"base_color": [0.7, 0.08, 0.05], "roughness": 0.35},
            "mesh": {"base_color": [0.2, 0.4, 0.8], "roughness": 0.4},
        },
        "objects": [
            _sphere(0.6, [-1.9, 0.0, 0.0], "white"),
            _sphere(0.6, [-0.6, 0.0, -0.5], "chrome"),
            _sphere(0.45, [0.55, -0.1, 0.4], "red"),
            {**_sphere(0.6, [1.9, 0.0, 0.0], "mesh"), "subdivisions": 3},
        ],
        "lights": [
            {"type": "directional", "direction": [0.4, -0.7, -0.6], "intensity": 2.5},
            {"type": "point", "position": [1.5, 3.0, 4.0], "intensity": 30.0, "range": 20.0},
        ],
    }


def with_aa(
    loaded: LoadedScene, mode: str, samples: int, supersample: int = 1, specular_aa: bool = False
) -> LoadedScene:
    """``loaded`` with ``render.antialiasing``, its samples, ``render.supersample`` and
    ``render.specular_aa`` set."""
    scene = loaded.scene
    update = {
        "antialiasing": mode, "antialiasing_samples": samples, "supersample": supersample,
        "specular_aa": specular_aa,
    }  # fmt: skip
    render = scene.render.model_copy(update=update)
    return dataclasses.replace(loaded, scene=replace_parts(scene, render=render))


def display(r: Renderer) -> np.ndarray:
    """The display image as float64 in 0..1."""
    return r.read_ldr().astype(np.float64) / 255.0


def _reference(
    ctx: Context, loaded: LoadedScene, factor: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``factor`` x ``factor`` supersampled display image; per pixel whether its block
    of G-buffer samples holds more than one surface or the background (a silhouette);
    and whether every sample of it lies on the smooth sphere (``SMOOTH``)."""
    r = Renderer(ctx.gl, with_aa(loaded, "none", 8, factor))
    try:
        r.render()
        image = display(r)
        g = r.read_gbuffer()
        smooth_id = r.frame.material_ids[SMOOTH][0]
    finally:
        r.release()
    w, h = r.size
    ids = np.where(g.covered, g.material_id.astype(np.int64), -1).reshape(h, factor, w, factor)
    low, high = ids.min(axis=(1, 3)), ids.max(axis=(1, 3))
    return image, low != high, (low == smooth_id) & (high == smooth_id)


def _errors(image: np.ndarray, reference: np.ndarray, mask: np.ndarray | None) -> float:
    """Mean absolute error per channel of display values over ``mask`` (None: all)."""
    diff = np.abs(image - reference).mean(axis=2)
    return float(diff.mean() if mask is None else diff[mask].mean())


def _dilate(mask: np.ndarray) -> np.ndarray:
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    return out


def jitter_display_mean(ctx: Context, loaded: LoadedScene, n: int) -> np.ndarray:
    """The mean of the display images of ``n`` jittered samples, each tone-mapped alone
    (``render_sample`` with a restarted mean), then averaged."""
    r = Renderer(ctx.gl, with_aa(loaded, "jitter", n))
    total = np.zeros((r.size[1], r.size[0], 3))
    try:
        for k in range(n):
            r.render_sample(k, restart=True)
            total += display(r)
    finally:
        r.release()
    return total / n


def run_antialiasing(ctx: Context) -> None:
    """Every candidate timed against "none" in alternating rounds; its display image's
    errors against the 4x4 and 8x8 supersampled frames over every pixel, the silhouettes
    and the highlight."""
    s = ctx.settings
    size = s.antialiasing_size
    loaded = scene_from(aa_scene_data(size))
    ctx.progress.start("antialiasing: references")
    ref4, edges, _ = _reference(ctx, loaded, 4)
    ref8, _, smooth = _reference(ctx, loaded, 8)
    ctx.progress.done()
    # the highlight: the smooth sphere's bright pixels in the 8x8 frame, and two around
    highlight = _dilate(_dilate(smooth & (ref8.max(axis=2) > HIGHLIGHT_LEVEL))) & smooth
    ctx.progress.start("antialiasing: candidates")
    renderers = {}
    try:
        for name, mode, n, specular_aa in CANDIDATES:
            renderers[name] = Renderer(ctx.gl, with_aa(loaded, mode, n, 1, specular_aa))
        times = ctx.time_interleaved(
            {name: [Pass("frame", r.render, None)] for name, r in renderers.items()},
            suite_budget(s),
        )
        images = {}
        for name, r in renderers.items():
            r.render()
            images[name] = display(r)
    finally:
        for r in renderers.values():
            r.release()
    images[f"jitter-display:{DISPLAY_MEAN_SAMPLES}"] = jitter_display_mean(
        ctx, loaded, DISPLAY_MEAN_SAMPLES
    )
    ctx.progress.done()
    base = np.asarray(times["none"].wall_ms)
    for name, image in images.items():
        t = times.get(name)
        # the median of the per-round ratios: a round times one frame of each variant,
        # so a change in the machine's load falls on both sides of each ratio
        ratio = None if t is None else float(np.median(np.asarray(t.wall_ms) / base))
        ctx.rows.append(
            make_row(
                SUITE, "spheres", name, size, 2, t,
                time_ratio=ratio,
                error_all_4=_errors(image, ref4, None),
                error_all_8=_errors(image, ref8, None),
                error_silhouette_4=_errors(image, ref4, edges),
                error_silhouette_8=_errors(image, ref8, edges),
                error_highlight_8=_errors(image, ref8, highlight),
                silhouette_pixels=int(edges.sum()),
                highlight_pixels=int(highlight.sum()),
                error_reference="mean |display - supersampled display| per channel, 0..1",
            )
        )  # fmt: skip

    run_showcase(ctx)


# The frame of the viewer's scene (scenes/showcase.toml at the viewer's window): the
# modes' cost on a frame of real work, the viewer target's measure.
SHOWCASE_MODES: tuple[tuple[str, str, int], ...] = (
    ("none", "none", 8),
    ("fxaa", "fxaa", 8),
    ("jitter:4", "jitter", 4),
    ("sraa", "sraa", 8),
    ("gbaa", "gbaa", 8),
    ("msaa", "msaa", 8),
)


# the viewer's frames (app/viewer/window.py INTERACTIVE): no render.gbaa_interior
VIEWER = RenderOptions(interactive=True)


def run_showcase(ctx: Context) -> None:
    """scenes/showcase.toml at ``antialiasing_viewer_size``: each of ``SHOWCASE_MODES``
    timed against "none" in alternating rounds (no error: it has no reference here)."""
    size = ctx.settings.antialiasing_viewer_size
    loaded = scene_from("showcase", size=size)
    ctx.progress.start("antialiasing: showcase")
    renderers = {}
    try:
        for name, mode, n in SHOWCASE_MODES:
            renderers[name] = Renderer(ctx.gl, with_aa(loaded, mode, n), size, options=VIEWER)
        times = ctx.time_interleaved(
            {name: [Pass("frame", r.render, None)] for name, r in renderers.items()},
            suite_budget(ctx.settings),
        )
        lights = len(renderers["none"].lights)
    finally:
        for r in renderers.values():
            r.release()
    ctx.progress.done()
    base = np.asarray(times["none"].wall_ms)
    for name, t in times.items():
        ratio = float(np.median(np.asarray(t.wall_ms) / base))
        ctx.rows.append(make_row(SUITE, "showcase", name, size, lights, t, time_ratio=ratio))


def suite_budget(settings: Settings) -> Budget:
    """The suite's frames: ``antialiasing_budget``, else the run's (a quick run times this
    suite as the full one does: its cost ratios against the aliased frame need the frames)."""
    return settings.antialiasing_budget or settings.budget


def antialiasing_tasks(settings: Settings) -> int:
    """The progress bar's ticks: warm-up and timed frames of every candidate."""
    b = suite_budget(settings)
    return (len(CANDIDATES) + len(SHOWCASE_MODES)) * (b.warmup + b.max_frames)
