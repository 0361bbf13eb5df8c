"""app/scene/placement.py: the model matrix without trimesh, bit for bit trimesh's."""

from __future__ import annotations

import math

import numpy as np
import trimesh

from app.scene.model import SceneObject
from app.scene.placement import axis_rotation, model_matrix

AXES = ([1, 0, 0], [0, 1, 0], [0, 0, 1])


def _angles() -> list[float]:
    rng = np.random.default_rng(7)
    special = [0.0, -0.0, 90.0, -90.0, 180.0, 45.0, 30.0, 360.0, 1e-12, -725.5]
    return [math.radians(a) for a in special + list(rng.uniform(-720.0, 720.0, 300))]


def test_axis_rotations_are_trimesh_bits() -> None:
    for angle in _angles():
        for axis, direction in enumerate(AXES):
            ours = axis_rotation(angle, axis)
            theirs = trimesh.transformations.rotation_matrix(angle, direction)
            assert ours.dtype == theirs.dtype
            assert ours.tobytes() == theirs.tobytes(), (angle, axis)


def test_model_matrix_is_trimesh_bits() -> None:
    rng = np.random.default_rng(11)
    for _ in range(200):
        rotation = [float(a) for a in rng.uniform(-400.0, 400.0, 3)]
        position = [float(p) for p in rng.uniform(-50.0, 50.0, 3)]
        scale = [float(s) for s in rng.uniform(0.01, 9.0, 3)]
        obj = SceneObject(
            shape="box", material="m", rotation=rotation, position=position, scale=scale
        )
        rx, ry, rz = (math.radians(a) for a in rotation)
        tt = trimesh.transformations
        r = (
            tt.rotation_matrix(rz, [0, 0, 1])
            @ tt.rotation_matrix(ry, [0, 1, 0])
            @ tt.rotation_matrix(rx, [1, 0, 0])
        )
        expected = tt.translation_matrix(position) @ r @ np.diag([*scale, 1.0])
        assert model_matrix(obj).tobytes() == expected.tobytes()
