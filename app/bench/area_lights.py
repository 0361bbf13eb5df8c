"""The ``shadows`` suite's case ``area lights`` (docs/area_lights.md): what one area light
costs against one point light of the same power, each shape in turn, on the suite's scene
(two spheres over a floor, no shadow maps). Time: the deferred frame (G-buffer and
lighting passes, ``frame_passes``) in alternating rounds; the lighting pass is where the
difference is (its ``passes_ms``)."""

from __future__ import annotations

from app.bench.context import Context, make_row
from app.bench.shadows import _load, frame_passes, shadow_scene  # the suite's scene
from app.render.renderer import Renderer

CASE = "area lights"
# One light 2 m over the spheres, the same c_light (power) in every shape.
AREA_LIGHTS = {
    "point": {"type": "point", "position": [0.3, 2.0, 0.6], "intensity": 6.0, "range": 9.0},
    "rect": {"type": "rect", "position": [0.3, 2.0, 0.6], "direction": [0.0, -1.0, -0.2],
             "size": [1.0, 0.5], "intensity": 6.0, "range": 9.0},
    "disk": {"type": "disk", "position": [0.3, 2.0, 0.6], "direction": [0.0, -1.0, -0.2],
             "radius": 0.4, "intensity": 6.0, "range": 9.0},
    "sphere": {"type": "sphere", "position": [0.3, 2.0, 0.6], "radius": 0.25,
               "intensity": 6.0, "range": 9.0},
    "tube": {"type": "tube", "position": [0.3, 2.0, 0.6], "direction": [1.0, 0.0, 0.0],
             "radius": 0.05, "length": 1.0, "intensity": 6.0, "range": 9.0},
}  # fmt: skip


def run_area_lights(ctx: Context) -> None:
    """One row per shape: the frame with that light, timed against the others."""
    size = ctx.settings.shadow_size
    ctx.progress.start("shadows: area lights against a point light")
    renderers = {}
    try:
        for kind, light in AREA_LIGHTS.items():
            renderers[kind] = Renderer(ctx.gl, _load(shadow_scene(light, size)), size)
        times = ctx.time_interleaved({k: frame_passes(r) for k, r in renderers.items()})
    finally:
        for r in renderers.values():
            r.release()
    for kind in AREA_LIGHTS:
        ctx.rows.append(make_row("shadows", CASE, kind, size, 1, times[kind], light_type=kind))
    ctx.progress.done()
