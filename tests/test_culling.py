"""Tiled light culling: conservative (no light that reaches a pixel is ever dropped), exact
(the culled image equals the unculled one bit for bit), and effective (a tile sees only a
fraction of the lights)."""

from __future__ import annotations

import numpy as np
import pytest

from app.reference.illumination import pixel_ndc
from app.reference.position import reconstruct_position
from app.render.culling import TILE_SIZE
from app.render.renderer import Renderer
from app.scene.loader import parse_scene


def many_lights_scene(count: int, culling: str, size: tuple[int, int] = (320, 180)) -> dict:
    """A floor with spheres under ``count`` coloured point and spot lights of 3 m range
    scattered over it, plus one directional light (deterministic)."""
    rng = np.random.default_rng(3)
    lights: list[dict] = [{"type": "directional", "direction": [0.3, -1.0, -0.2], "intensity": 0.3}]
    for i in range(count):
        x, z = rng.uniform(-14.0, 14.0, 2)
        light = {
            "type": "point" if i % 4 else "spot",
            "position": [float(x), float(rng.uniform(0.3, 3.0)), float(z)],
            "color": [float(c) for c in rng.uniform(0.2, 1.0, 3)],
            "intensity": 4.0,
            "range": 3.0,
        }
        if light["type"] == "spot":
            light["direction"] = [0.0, -1.0, 0.1]
        lights.append(light)
    spheres = [
        {
            "shape": "sphere",
            "radius": 1.0,
            "material": "ball",
            "position": [float(x), 1.0, float(z)],
        }
        for x, z in rng.uniform(-8.0, 8.0, (12, 2))
    ]
    return {
        "camera": {"position": [0.0, 9.0, 16.0]},
        "render": {"width": size[0], "height": size[1], "light_culling": culling},
        "materials": {
            "floor": {"base_color": [0.7, 0.7, 0.7], "roughness": 0.6},
            "ball": {"base_color": [0.8, 0.3, 0.2], "roughness": 0.3, "ndf": "beckmann"},
        },
        "lights": lights,
        "objects": [{"shape": "plane", "size": [40.0, 40.0], "material": "floor"}, *spheres],
    }


def render_hdr(gl, data: dict) -> tuple[np.ndarray, Renderer]:
    renderer = Renderer(gl, parse_scene(data, "many-lights.toml"))
    renderer.render()
    return renderer.read_hdr(), renderer


@pytest.mark.parametrize("count", [40, 300, 1100])  # 1100: two rows of the light texture
def test_culled_image_equals_unculled(gl, count: int) -> None:
    culled, r1 = render_hdr(gl, many_lights_scene(count, "tiled"))
    plain, r2 = render_hdr(gl, many_lights_scene(count, "none"))
    try:
        assert r1.culler is not None and r2.culler is None
        assert np.isfinite(culled).all() and culled.max() > 1.0
        # Same lights, same order, minus lights that add exactly 0: identical sums.
        assert np.array_equal(culled, plain)
    finally:
        r1.release()
        r2.release()


def test_culling_is_conservative_and_effective(gl_egl) -> None:
    _, r = render_hdr(gl_egl, many_lights_scene(300, "tiled"))
    try:
        masks = r.culler.read_masks()  # (tiles_y, tiles_x, lights), tile rows bottom-up
        g = r.read_gbuffer()
        local = [x for x in r.lights if x["type"] != 0]
    finally:
        r.release()
    h, w = g.depth.shape
    covered = g.depth > 0.0
    p = reconstruct_position(
        pixel_ndc(h, w)[covered], g.depth[covered], r.camera.position,
        r.camera.camera_to_world, r.camera.tan_half_fov,
    )  # fmt: skip
    rows, cols = np.nonzero(covered)
    tile_y, tile_x = (h - 1 - rows) // TILE_SIZE, cols // TILE_SIZE
    needed = np.zeros_like(masks)
    for j, light in enumerate(local):
        reach = np.linalg.norm(p - light["position"], axis=1) < light["range"]
        needed[tile_y[reach], tile_x[reach], j] = True
    assert needed.sum() > 1000, "too few light-tile pairs to mean anything"
    assert not np.any(needed & ~masks), "a light that reaches a pixel was culled"
    # Effective: each tile keeps a small fraction of the 300 lights, and not many more
    # than it needs (the plane tests are conservative near the tile frustum's corners).
    assert masks.sum(axis=-1).max() < 0.25 * len(local)
    assert masks.sum() < 3.0 * needed.sum()
