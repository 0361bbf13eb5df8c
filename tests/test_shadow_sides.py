"""Shadows respect a glTF material's ``doubleSided`` (docs/shadows.md, "Single-sided
surfaces"): a single-sided panel casts only with its face towards the light, as the camera
sees only its front; a double-sided one casts with either side.

The scene: a floor (4 x 4 m, double-sided, z = 0, facing the camera at z = 3) and a 1 x 1 m
panel at z = 1 in front of its centre, its front towards the camera and the light (+Z) or
away from both (-Z). A light from the camera's side, tilted along +x, throws the panel's
shadow onto the floor at x in [0.5, 1.5]; the camera sees the floor from x = 0.75 outwards
past the panel (all of it where the panel is culled). The floor at x = +1.1 (in the
shadow) is compared with the same pixel under the light with its shadow off.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.render.renderer import Renderer
from app.scene.loader import load_scene
from app.scene.model import Light
from tests.gltf_builder import GltfBuilder

pytestmark = pytest.mark.gl

N = 64
FOV = 60.0
CAMERA_Z = 3.0
PROBE_X = 1.1  # metres on the floor, either side of the centre
SCENE = f"""\
[camera]
position = [0.0, 0.0, {CAMERA_Z}]
target = [0.0, 0.0, 0.0]
fov_y = {FOV}

[[objects]]
shape = "mesh"
file = "m.glb"
"""
# glTF quaternion (x, y, z, w) of a half turn about +Y: the quad then faces -Z.
HALF_TURN = [0.0, 1.0, 0.0, 0.0]
LIGHTS = {
    "directional": Light(
        type="directional", direction=[1.0, 0.0, -1.0], intensity=2.0, shadow=True
    ),
    "spot": Light(
        type="spot", position=[-3.0, 0.0, 4.0], direction=[1.0, 0.0, -1.0], intensity=60.0,
        range=20.0, inner_angle=40.0, outer_angle=50.0, shadow=True,
    ),
    "point": Light(
        type="point", position=[-3.0, 0.0, 4.0], intensity=60.0, range=20.0, shadow=True
    ),
}  # fmt: skip


def panel_scene(tmp_path: Path, double_sided: bool, facing_light: bool) -> Path:
    b = GltfBuilder()
    pbr = pygltflib.PbrMetallicRoughness(
        baseColorFactor=[0.8, 0.8, 0.8, 1.0], metallicFactor=0.0, roughnessFactor=0.7
    )
    floor = b.material(pygltflib.Material(pbrMetallicRoughness=pbr, doubleSided=True))
    panel = b.material(pygltflib.Material(pbrMetallicRoughness=pbr, doubleSided=double_sided))
    b.quad(floor, scale=[2.0, 2.0, 1.0])
    turn = {} if facing_light else {"rotation": HALF_TURN}
    b.quad(panel, translation=[0.0, 0.0, 1.0], scale=[0.5, 0.5, 1.0], **turn)
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE, encoding="utf-8")
    return scene


def floor_column(x: float) -> int:
    """The image column that sees the floor (z = 0) at ``x`` on the centre row."""
    ndc = x / (CAMERA_Z * math.tan(math.radians(FOV / 2)))
    return int((ndc + 1.0) * 0.5 * N)


def visibility(gl, scene: Path, light: Light) -> float:
    """The floor's luminance in the panel's shadow over its luminance with the light's
    shadow off: the light's visibility there."""
    r = Renderer(gl, load_scene(scene), (N, N))
    probe = (N // 2, floor_column(PROBE_X))
    try:
        values = []
        for shadow in (True, False):
            r.set_lights([light.model_copy(update={"shadow": shadow})])
            r.render()
            values.append(float(r.read_hdr().astype(np.float64)[probe].sum()))
    finally:
        r.release()
    assert values[1] > 0.0
    return values[0] / values[1]


@pytest.mark.parametrize("light", list(LIGHTS))
@pytest.mark.parametrize(
    ("double_sided", "facing_light", "casts"),
    [(False, False, False), (False, True, True), (True, False, True)],
    ids=["single-sided-away", "single-sided-towards", "double-sided-away"],
)
def test_a_single_sided_panel_casts_only_with_its_front(
    gl_egl, tmp_path, light, double_sided, facing_light, casts
):
    ratio = visibility(gl_egl, panel_scene(tmp_path, double_sided, facing_light), LIGHTS[light])
    if casts:
        assert ratio < 0.2, ratio
    else:
        assert ratio == pytest.approx(1.0, abs=1e-3), ratio
