"""The pyrender comparison scene and frame (app/bench/spheres.py): the scene is the
one docs/performance.md describes, and the frame the bench times pass by pass is the renderer's own
frame to the 8-bit image. No test here asserts a time."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.bench.context import TINY, Context
from app.bench.scenes import load
from app.bench.sphere_grid import RADIUS, SPACING
from app.bench.spheres import pbs_frame_passes, run_pyrender_spheres, sphere_grid_scene
from app.progress import Progress
from app.render.renderer import Renderer

SIZE = (96, 54)


def test_sphere_grid_is_the_35_sphere_scene():
    data = sphere_grid_scene(4, (1280, 720))
    spheres = data["objects"]
    assert len(spheres) == 35 and {o["subdivisions"] for o in spheres} == {4}
    assert {o["radius"] for o in spheres} == {RADIUS}
    xs = sorted({o["position"][0] for o in spheres})
    ys = sorted({o["position"][1] for o in spheres})
    assert len(xs) == 7 and len(ys) == 5 and np.allclose(np.diff(xs), SPACING)
    assert np.allclose(np.diff(ys), SPACING)
    metallic = {m["metallic"] for m in data["materials"].values()}
    roughness = {m["roughness"] for m in data["materials"].values()}
    assert metallic == {0.0, 1.0} and len(roughness) == 7
    assert data["camera"]["fov_y"] == 45.0 and data["camera"]["position"][2] == 9.0
    lights = data["lights"]
    assert len(lights) == 4 and all(x["type"] == "point" and x["range"] == 100.0 for x in lights)
    assert all(x["position"][2] > RADIUS for x in lights)  # in front of the grid
    assert len(sphere_grid_scene(1, (64, 36))["lights"]) == 1


@pytest.mark.parametrize("mode", ["default", "gbaa"])
def test_frame_passes_draw_the_renderers_frame(gl_egl, mode):
    """The timed passes, run in order, end with the image render() + read_ldr() give; the
    read-back pass returns it (a pass left out would leave another image). A plain frame
    has no post pass (the lighting pass writes the display image); with ``fuse_post`` off
    it has one, and the same image. The 35 mesh spheres (179,200 triangles) draw FXAA by
    default (past GBAA_DEFAULT_TRIANGLES) and gbaa where the scene names it."""
    data = sphere_grid_scene(2, SIZE)
    if mode != "default":
        data = {**data, "render": {**data.get("render", {}), "antialiasing": mode}}
    r = Renderer(gl_egl, load(data), SIZE)
    images, names = [], []
    try:
        r.render()
        expected = r.read_ldr()
        for fuse in (True, False):
            r.set_options(dataclasses.replace(r.options, fuse_post=fuse))
            r.post.fbo.clear(0.0, 0.0, 0.0, 1.0)
            passes = pbs_frame_passes(r)
            names.append([p.name for p in passes])
            for p in passes[:-1]:
                p.run()
            images.append(r.read_ldr())
    finally:
        r.release()
    # two lights: the default light_culling ("auto") draws them without tiles
    aa = "fxaa" if mode == "default" else mode
    assert names == [["gbuffer", "lighting", aa, "read-back"],
                     ["gbuffer", "lighting", "post", aa, "read-back"]]  # fmt: skip
    assert expected.shape == (SIZE[1], SIZE[0], 3) and expected.max() > 50
    for image in images:
        assert np.array_equal(image, expected)


def test_without_pyrender_the_comparison_says_why(gl_egl):
    """Run with an interpreter that cannot import pyrender (the tests' own), the rows are
    left out and a note names the reason."""
    import importlib.util

    ctx = Context(gl_egl, TINY, None, Progress(1, enabled=False))
    run_pyrender_spheres(ctx)
    if importlib.util.find_spec("pyrender") is None:
        assert ctx.rows == [] and "pyrender" in ctx.notes[0]
    else:  # the bench extra is installed: one row per renderer, ratios per round
        assert {r["variant"] for r in ctx.rows} == {"pbs render+read-back", "pyrender"}
        assert all(r["pyrender_over_pbs"]["median"] > 0.0 for r in ctx.rows)
