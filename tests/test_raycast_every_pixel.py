"""Every pixel against the pixel-area-integrated ray-cast (app/reference/raycast.py
``area_reference``; docs/accuracy.md, "Every pixel"): the truth's coverage mix by hand, its
sample pattern, and the renderer's every-pixel error falling as its samples grow."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.bench.raycast import (
    every_pixel_floor,
    every_pixel_row,
    five_spheres,
    gpu_images,
    parse_overrides,
    pixel_centres,
    with_settings,
)
from app.common.camera import CameraFrame
from app.common.lights import LightType, PunctualLight
from app.common.models import DEFAULT_MODEL, ModelParams
from app.common.primitives import Primitive
from app.frame.raycast import area_reference_scene, reference_scene
from app.reference.material import Surface
from app.reference.raycast import (
    MIXED,
    PrimitiveMaterial,
    area_reference,
    edge_mask,
    multi_jittered,
    render_reference,
)
from app.reference.tonemap import post_process, srgb_decode
from app.scene.loader import LoadedScene, load_scene, parse_scene
from tests.conftest import REPO

SIZE = (41, 31)  # odd: the middle column is centred on x = 0
TAN = math.tan(math.radians(30.0) / 2.0)
LAMBERT = PrimitiveMaterial(
    Surface(np.array([0.6, 0.4, 0.2]), 0.0, 0.5, 0.04), ModelParams(), DEFAULT_MODEL
)
SUN = PunctualLight(LightType.DIRECTIONAL, np.zeros(3), np.array([0.0, 0.0, -1.0]), np.full(3, 2.0))
BACKGROUND = np.array([0.1, 0.2, 0.3])


def _left_half_wall() -> tuple[list[Primitive], CameraFrame]:
    """A wall facing the camera (at the origin, looking down -Z) 5 m away, covering x <= 0:
    its edge runs down the middle of the middle pixel column."""
    w, h = SIZE
    model = np.eye(4)
    model[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # the plane's +Y normal to +Z
    model[:3, 3] = (-5.0, 0.0, -5.0)
    cam = CameraFrame(np.zeros(3), np.eye(3), (TAN * w / h, TAN), 0.05, 100.0)
    return [Primitive("plane", model, size=(10.0, 10.0))], cam


def test_truth_mixes_surface_and_background_by_coverage():
    """The pixel the wall's edge halves holds half the wall's radiance and half the
    background's; the pixel-centre image gives it all to one side, and the area truth
    with one sample per pixel is that image exactly."""
    prims, cam = _left_half_wall()
    args = ([LAMBERT], cam, SIZE, [SUN], BACKGROUND, "diffuse")
    truth = area_reference(prims, *args, samples=4, edge_samples=8)
    centre = render_reference(prims, *args)
    mid = SIZE[0] // 2
    wall, bg = truth.hdr[:, mid - 2], truth.hdr[:, mid + 2]
    assert np.allclose(wall, LAMBERT.surface.base_color * 2.0, rtol=1e-12)  # albedo E cos
    assert np.allclose(bg, BACKGROUND, rtol=1e-12)
    assert np.allclose(truth.hdr[:, mid], 0.5 * (wall + bg), rtol=1e-12)
    assert np.all(truth.ids[:, mid] == MIXED) and np.all(truth.ids[:, mid - 2] == 0)
    assert not np.allclose(centre.hdr[:, mid], 0.5 * (wall + bg), rtol=1e-3)
    edge = edge_mask(truth.ids)
    assert edge[:, mid - 1 : mid + 2].all() and not edge[:, : mid - 1].any()
    one = area_reference(prims, *args, samples=1, edge_samples=1)
    assert np.array_equal(one.hdr, centre.hdr) and np.array_equal(one.ids, centre.ids)


def test_multi_jittered_pattern_is_stratified_both_ways():
    """One sample in each of the n x n cells and in each of the n^2 columns and rows."""
    n = 5
    p = multi_jittered(n) + 0.5
    assert p.shape == (n * n, 2) and np.all((p > 0.0) & (p < 1.0))
    cells = set(zip((p[:, 0] * n).astype(int), (p[:, 1] * n).astype(int), strict=True))
    assert len(cells) == n * n
    assert len(set((p[:, 0] * n * n).astype(int))) == n * n
    assert len(set((p[:, 1] * n * n).astype(int))) == n * n


@pytest.mark.parametrize("name", ["ibl_sky", "shadows"])
def test_one_sample_area_truth_is_the_pixel_centre_reference(name):
    """With one sample per pixel the area truth of a scene, an environment drawn behind it
    (ibl_sky) and shadow rays (shadows) included, is app/frame/raycast.py's pixel-centre
    reference, bit for bit: the two share rays, background and shading."""
    loaded = load_scene(REPO / "scenes" / f"{name}.toml")
    size = (24, max(8, round(24 * loaded.scene.render.height / loaded.scene.render.width)))
    one = area_reference_scene(loaded, size, 1, 1)
    centre = reference_scene(loaded, size)
    assert np.array_equal(one.hdr, centre.hdr) and np.array_equal(one.ids, centre.ids)
    assert np.ptp(one.hdr[~one.covered]) > 0.0 if name == "ibl_sky" else True


def test_settings_overrides_are_validated():
    loaded = five_spheres()
    assert parse_overrides("render.supersample=4, render.gbuffer=f16") == {
        "render.supersample": 4,
        "render.gbuffer": "f16",
    }
    assert parse_overrides("") == {}
    changed = with_settings(loaded, {"render.supersample": 2})
    assert changed.scene.render.supersample == 2 and loaded.scene.render.supersample == 1
    with pytest.raises(ValueError, match=r"render\.supersample"):
        with_settings(loaded, {"render.supersample": 0})
    with pytest.raises(ValueError, match=r"render\.no_such_key"):
        with_settings(loaded, {"render.no_such_key": 1})


# Measured on llvmpipe at 96 x 54 against the 4 x 4 (16 x 16 on edges) truth: mean FLIP
# 2.3e-2 with one sample per pixel, 8.5e-3 with supersample 2, 5.4e-3 with 4.
SIZE_GL = (96, 54)
SUPERSAMPLE_4_FLIP = 7e-3


@pytest.fixture(scope="module")
def truth():
    return area_reference_scene(five_spheres(), SIZE_GL, 4, 16)


def test_every_pixel_error_falls_as_the_renderer_supersamples(gl_egl, truth):
    """The aliased frame is far from the area truth at its edges and supersampling brings it
    in: the every-pixel metric can fail (one sample per pixel) and pass (4 x 4)."""
    loaded = pixel_centres(five_spheres())  # one sample per pixel unless supersampled
    rows = [
        every_pixel_row(gl_egl, loaded, SIZE_GL, truth, {"render.supersample": n})
        for n in (1, 2, 4)
    ]
    flips = [r["flip_mean"] for r in rows]
    assert flips[0] > 3.0 * flips[2], rows
    assert flips[0] > flips[1] > flips[2], rows
    assert flips[0] > SUPERSAMPLE_4_FLIP, rows
    assert flips[2] <= SUPERSAMPLE_4_FLIP, rows
    assert rows[0]["flip_edge"] > 3.0 * rows[0]["flip_interior"], rows
    assert rows[0]["rel_rmse"] > 3.0 * rows[2]["rel_rmse"], rows


def test_floor_parts_rank_as_measured(gl_egl, truth):
    """every_pixel_floor's parts at 96 x 54: rounding one side alone is far above a
    converged frame's FLIP, the 8 x 8 box below the 4 x 4 and both far below the aliased
    frame, the default between, and rounding both sides adds little to a box's float FLIP."""
    e = every_pixel_floor(gl_egl, five_spheres(), SIZE_GL, truth)
    assert e["8x8_8bit"] < e["4x4_8bit"] < e["defaults_8bit"] < e["none_8bit"], e
    assert e["4x4_8bit"] < e["none_8bit"] / 3.0 and e["quantisation"] > 3.0 * e["8x8_8bit"], e
    assert abs(e["8x8_8bit"] - e["8x8_float"]) < 1e-3 and e["defaults_float"] is None, e


def _retro_spheres() -> LoadedScene:
    """Two rough Lambert spheres lit from exactly behind a far camera (sec9_diffuse_retro's
    setting): n.l falls to 0 all around each silhouette, the steepest rim there is."""
    objects = [
        {"shape": "sphere", "radius": 0.5, "position": [x, 0.0, 0.0], "material": "clay"}
        for x in (-0.625, 0.625)
    ]
    return parse_scene(
        {
            "background": [0.03, 0.035, 0.045],
            "render": {"width": 64, "height": 40, "tonemap": "neutral"},
            "camera": {"position": [0.0, 0.0, 300.0], "target": [0.0, 0.0, 0.0],
                       "fov_y": 0.3, "near": 250.0, "far": 350.0},
            "materials": {"clay": {"base_color": [0.6, 0.28, 0.14], "roughness": 1.0}},
            "lights": [{"type": "directional", "direction": [0.0, 0.0, -1.0]}],
            "objects": objects,
        },
        Path("retro.toml"),
    )  # fmt: skip


def test_gbaa_rim_takes_the_covered_part_s_shading(gl_egl):
    """gbaa's edge pixels are shaded at their covered part's centroid, not at the pixel
    centre that lies nearer the silhouette: on a rim whose n.l falls to 0 the centre's
    shading drew a line darker (inside) and brighter (outside) than the area truth, and the
    display image was 1.19x further from it than the aliased frame's (mean absolute error
    of linear display values over the image); now 0.83x."""
    loaded = _retro_spheres()
    size = (64, 40)
    truth = area_reference_scene(loaded, size, 4, 16)
    want = srgb_decode(np.clip(post_process(truth.hdr, 0.0, "neutral"), 0.0, 1.0))
    err = {}
    for mode in ("none", "gbaa"):
        _, ldr = gpu_images(gl_egl, with_settings(loaded, {"render.antialiasing": mode}), size)
        err[mode] = float(np.abs(srgb_decode(ldr) - want).mean())
    assert err["gbaa"] < err["none"], err


def test_the_doc_table_is_the_json():
    """docs/accuracy.md's every-pixel section is what scripts/accuracy_doc.py makes of
    docs/accuracy_every_pixel.json (a hand edit of either fails here)."""
    from scripts.accuracy_doc import JSON, main

    assert main(["--from-json", str(JSON), "--check"]) == 0


def test_gbaa_interior_takes_the_pixel_s_area_mean(gl_egl):
    """gbaa's third draw moves each interior pixel (every 4-neighbour the same surface) from
    its centre's radiance toward the pixel's area mean by the box filter's 5-tap correction:
    away from the silhouettes the display image comes closer to the area truth than the
    aliased frame's, which the default drew there before (the same bytes). Measured on
    llvmpipe at 160 x 90 (mean absolute error of linear display values over the pixels
    2 px or more inside a silhouette): 0.74x the aliased frame's; 1.00x without the draw."""
    loaded = five_spheres()
    size = (160, 90)
    truth = area_reference_scene(loaded, size, 4, 16)
    inside = ~edge_mask(truth.ids, 2)
    want = srgb_decode(np.clip(post_process(truth.hdr, 0.0, "neutral"), 0.0, 1.0))[inside]
    err = {}
    for mode in ("none", "gbaa"):
        _, ldr = gpu_images(gl_egl, with_settings(loaded, {"render.antialiasing": mode}), size)
        err[mode] = float(np.abs(srgb_decode(ldr)[inside] - want).mean())
    assert err["gbaa"] < 0.85 * err["none"], err
