"""Camera matrices (column-vector convention, float64).

pyrr builds its matrices for row vectors (``v @ M``); they are transposed here once so
that the rest of the code reads like the maths (``M @ v``). For upload to GL, whose
uniforms are column-major, ``gl_bytes`` writes ``M.T`` in C order.
"""

from __future__ import annotations

import math

import numpy as np
from pyrr import matrix44

from app.common.camera import CameraFrame
from app.scene.model import Camera


def view_matrix(cam: Camera) -> np.ndarray:
    """World -> view (right-handed, looking down -Z)."""
    m = matrix44.create_look_at(
        np.array(cam.position, np.float64),
        np.array(cam.target, np.float64),
        np.array(cam.up, np.float64),
        dtype=np.float64,
    )
    return np.asarray(m, np.float64).T


def projection_matrix(cam: Camera, aspect: float) -> np.ndarray:
    """View -> clip, OpenGL depth range [-1, 1]."""
    m = matrix44.create_perspective_projection(
        cam.fov_y, aspect, cam.near, cam.far, dtype=np.float64
    )
    return np.asarray(m, np.float64).T


def gl_bytes(m: np.ndarray) -> bytes:
    """A column-vector matrix as the column-major float32 bytes a GL uniform expects."""
    return np.ascontiguousarray(np.asarray(m).T, dtype=np.float32).tobytes()


def camera_frame(cam: Camera, width: int, height: int) -> CameraFrame:
    """The camera's frame for position reconstruction (glsl/common/position.glsl)."""
    t = math.tan(math.radians(cam.fov_y) / 2.0)
    return CameraFrame(
        position=np.asarray(cam.position, np.float64),
        camera_to_world=view_matrix(cam)[:3, :3].T,
        tan_half_fov=(t * width / height, t),
        near=cam.near,
        far=cam.far,
    )
