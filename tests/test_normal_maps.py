"""Tangent-space normal mapping through the real G-buffer pass: the convention (+x along
+u, +y along +v, +z along the surface normal; docs/scene-format.md) holds in world space,
also where the model matrix mirrors the mesh."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.render import renderer as renderer_module
from app.render.renderer import Renderer
from app.scene.geometry import build_parts
from app.scene.loader import load_scene

SCENE = """
[render]
width = 32
height = 32
gbuffer = "f32"

[camera]
position = [0.0, 4.0, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_y = 20.0

[materials.m]
normal_map = "n.png"

[[objects]]
shape = "plane"
size = [4.0, 4.0]
material = "m"

[[lights]]
type = "directional"
direction = [0.0, -1.0, 0.0]
"""

TILT = math.radians(30.0)


@pytest.mark.parametrize("mirrored", [False, True], ids=["plain", "mirrored"])
@pytest.mark.parametrize(
    ("tangent_space", "world"),
    [
        # The plane's +u runs along +x and +v along -z (app/scene/geometry.py _plane).
        ((math.sin(TILT), 0.0, math.cos(TILT)), (math.sin(TILT), math.cos(TILT), 0.0)),
        ((0.0, math.sin(TILT), math.cos(TILT)), (0.0, math.cos(TILT), -math.sin(TILT))),
    ],
    ids=["tilt-u", "tilt-v"],
)
def test_normal_map_tilts_the_world_normal(
    gl_egl: GLContext,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    mirrored: bool,
    tangent_space: tuple,
    world: tuple,
) -> None:
    """A constant normal map tilted 30 degrees towards +u (or +v) tilts the G-buffer
    normal 30 degrees towards the world direction of +u (or +v); mirroring the plane in x
    mirrors +u but not +v, and the tangent frame's handedness follows. (Scene files allow
    only positive scales; a glTF node can mirror, so the test mirrors the part's model
    matrix as such a node would.)"""
    rgb = np.round((np.asarray(tangent_space) * 0.5 + 0.5) * 255.0).astype(np.uint8)
    Image.fromarray(np.tile(rgb, (4, 4, 1))).save(tmp_path / "n.png")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE, encoding="utf-8")
    if mirrored:

        def mirrored_parts(loaded: object) -> list:
            parts = build_parts(loaded)
            for part in parts:
                part.model = np.diag([-1.0, 1.0, 1.0, 1.0]) @ part.model
            return parts

        monkeypatch.setattr(renderer_module, "build_parts", mirrored_parts)
    r = Renderer(gl_egl, load_scene(scene))
    try:
        r.render()
        g = r.read_gbuffer()
    finally:
        r.release()
    n = oct_decode(g.normal[16, 16, :2].astype(np.float64))
    want = np.array(world)
    if mirrored:
        want[0] = -want[0]
    # 8-bit quantisation of the map: under 0.5 degrees.
    assert np.degrees(np.arccos(np.clip(n @ want, -1, 1))) < 0.5, (n, want)
