"""RTR4 §9.4 (scenes/sec4_lights.toml): punctual lights summed in one lighting pass,
each point and spot light windowed to exactly zero at its range (and a spot beyond its
outer cone), so the lights can be culled without changing a pixel."""

from __future__ import annotations

import numpy as np

from app.bench.pairs import light_pairs
from app.common.lights import LightType
from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.reference.illumination import surface_positions
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene, load_scene
from tests.agreement import without_shadows
from tests.conftest import REPO

SCENE = REPO / "scenes" / "sec4_lights.toml"


def _render(gl: GLContext, loaded: LoadedScene) -> tuple[np.ndarray, Renderer]:
    r = Renderer(gl, loaded)
    r.render()
    return r.read_hdr(), r


def _lit_side(p: np.ndarray, n: np.ndarray, lights: list[dict]) -> np.ndarray:
    """(C,) bool: some point or spot light reaches the point (closer than its range,
    inside its outer cone) from the side its normal faces (n.l > 0)."""
    out = np.zeros(len(p), bool)
    for light in lights:
        if light.type == LightType.DIRECTIONAL:
            continue
        d = np.asarray(light.position, np.float64) - p
        dist = np.linalg.norm(d, axis=-1)
        ok = (dist < light.range) & (np.sum(n * d, axis=-1) > 0.0)
        if light.type == LightType.SPOT:
            ok &= -(d @ np.asarray(light.direction, np.float64)) > light.cos_outer * dist
        out |= ok
    return out


def test_local_lights_add_exactly_nothing_beyond_their_reach(gl_egl: GLContext) -> None:
    """Where no point or spot light reaches (app/bench/pairs.py: farther than its range,
    or outside its outer cone, in float64 on the G-buffer's positions), the image equals
    the moonlight-only image bit for bit (70 % of the surface pixels, measured). Where one
    reaches from the side the surface faces, the pixel is brighter: all but 15 of 113,747
    pixels, the last sliver of a window where the added light is below float32's
    resolution of the sum. Without the spots' shadows (a shadowed pixel gains nothing)."""
    loaded = without_shadows(load_scene(SCENE))
    full, r = _render(gl_egl, loaded)
    try:
        g = r.read_gbuffer()
        pairs = light_pairs(g, r.camera, r.lights)
        covered, p = surface_positions(g, r.camera)
        lit = _lit_side(p, oct_decode(np.asarray(g.normal[..., :2], np.float64))[covered],
                        r.lights)  # fmt: skip
        directional = sum(1 for light in r.lights if light.type == LightType.DIRECTIONAL)
    finally:
        r.release()
    lights = [x for x in loaded.scene.lights if x.type == "directional"]
    moon, r2 = _render(gl_egl, LoadedScene(loaded.scene.model_copy(update={"lights": lights}),
                                           loaded.path))  # fmt: skip
    r2.release()
    assert directional == 1
    unreached = covered & (pairs.count == directional)
    assert unreached.sum() > 0.5 * covered.sum()
    assert np.array_equal(full[unreached], moon[unreached])
    brighter = (full[covered] > moon[covered]).any(axis=-1)
    assert lit.sum() > 0.2 * covered.sum()
    assert brighter[lit].mean() > 0.999
