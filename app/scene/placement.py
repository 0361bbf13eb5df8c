"""Where a scene object stands: its model matrix from ``scale``, ``rotation`` and
``position``. Apart from the geometry, so that what only places things (a glTF file's
cameras and lights, the ray-caster's primitives) needs no mesh code."""

from __future__ import annotations

import math

import numpy as np

from app.scene.model import SceneObject


def model_matrix(obj: SceneObject) -> np.ndarray:
    """T @ Rz @ Ry @ Rx @ S: scale, then rotate about X, Y, Z (degrees), then translate.
    trimesh is imported here, not with the module: the scene loader imports this module
    (a glTF file's cameras and lights), and a scene refused by validation needs no mesh
    library (docs/performance.md, "Start-up")."""
    import trimesh

    scale = np.broadcast_to(np.asarray(obj.scale, np.float64), (3,))
    rx, ry, rz = (math.radians(a) for a in obj.rotation)
    r = (
        trimesh.transformations.rotation_matrix(rz, [0, 0, 1])
        @ trimesh.transformations.rotation_matrix(ry, [0, 1, 0])
        @ trimesh.transformations.rotation_matrix(rx, [1, 0, 0])
    )
    t = trimesh.transformations.translation_matrix(obj.position)
    return t @ r @ np.diag([*scale, 1.0])
