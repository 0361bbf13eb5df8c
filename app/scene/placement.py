"""Where a scene object stands: its model matrix from ``scale``, ``rotation`` and
``position``. Apart from the geometry, so that what only places things (a glTF file's
cameras and lights, the ray-caster's primitives) needs no mesh code."""

from __future__ import annotations

import math

import numpy as np

from app.scene.model import SceneObject


def model_matrix(obj: SceneObject) -> np.ndarray:
    """T @ Rz @ Ry @ Rx @ S: scale, then rotate about X, Y, Z (degrees), then translate."""
    scale = np.broadcast_to(np.asarray(obj.scale, np.float64), (3,))
    rx, ry, rz = (math.radians(a) for a in obj.rotation)
    r = axis_rotation(rz, 2) @ axis_rotation(ry, 1) @ axis_rotation(rx, 0)
    t = np.eye(4)
    t[:3, 3] = obj.position
    return t @ r @ np.diag([*scale, 1.0])


def axis_rotation(angle: float, axis: int) -> np.ndarray:
    """The 4x4 rotation by ``angle`` radians about coordinate axis ``axis`` (0: X, 1: Y,
    2: Z), counter-clockwise looking down the axis: Rodrigues' formula
    cos I + (1 - cos) a a^T + sin [a]x for a unit axis a. The axis's own diagonal entry is
    ``cos + (1 - cos)``, summed in that order (not 1): the same bits as the matrices
    trimesh.transformations.rotation_matrix made when this module called it, so placed
    objects and the images of every scene stay bit for bit the same (tests/test_placement.py);
    trimesh is no longer imported to place a glTF file (docs/performance.md, "Start-up")."""
    sin, cos = np.sin(angle), np.cos(angle)
    m = np.diag([cos, cos, cos, 1.0])
    m[axis, axis] += 1.0 - cos
    i, j = (axis + 1) % 3, (axis + 2) % 3
    m[j, i] += sin
    m[i, j] += -sin
    return m
