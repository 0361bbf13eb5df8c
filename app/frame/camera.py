"""Camera matrices (column-vector convention, float64: the code reads like the maths,
``M @ v``). For upload to GL, whose uniforms are column-major, ``gl_bytes`` writes
``M.T`` in C order.
"""

from __future__ import annotations

import math

import numpy as np

from app.common.camera import CameraFrame
from app.scene.loader import LoadedScene
from app.scene.model import Camera


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.sqrt(np.sum(v * v))


def view_matrix(cam: Camera) -> np.ndarray:
    """World -> view (right-handed, looking down -Z; gluLookAt's matrix): the rows are
    the camera's right, up and backward axes, and the translation moves the eye to the
    origin."""
    eye = np.array(cam.position, np.float64)
    forward = _unit(np.array(cam.target, np.float64) - eye)
    right = _unit(np.cross(forward, np.array(cam.up, np.float64)))
    up = _unit(np.cross(right, forward))
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = right, up, -forward
    m[:3, 3] = -np.dot(right, eye), -np.dot(up, eye), np.dot(forward, eye)
    return m


def projection_matrix(cam: Camera, aspect: float) -> np.ndarray:
    """View -> clip, OpenGL depth range [-1, 1] (gluPerspective's matrix, ``fov_y`` in
    degrees): x and y scaled by near over the near plane's half extents, z mapped so that
    -near and -far land on -1 and 1, w = -z."""
    near, far = float(cam.near), float(cam.far)
    half_h = near * math.tan(cam.fov_y * math.pi / 360.0)
    half_w = half_h * aspect
    m = np.zeros((4, 4))
    m[0, 0] = near / half_w
    m[1, 1] = near / half_h
    m[2, 2] = -(far + near) / (far - near)
    m[2, 3] = -2.0 * far * near / (far - near)
    m[3, 2] = -1.0
    return m


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


# A fitted field of view stays below this (degrees): the scene format's fov_y < 180.
MAX_FIT_FOV_Y = 170.0


def fit_fov_y(fov_y: float, scene_aspect: float, aspect: float) -> float:
    """The vertical field of view (degrees) that shows at ``aspect`` (width / height) all
    that ``fov_y`` shows at ``scene_aspect``: where the image is narrower, the horizontal
    extent is kept, so tan(fov/2) grows by scene_aspect / aspect; where it is wider, the
    vertical one is kept (``fov_y`` unchanged) and more is seen at the sides. Capped at
    ``MAX_FIT_FOV_Y`` for extreme ratios."""
    if aspect >= scene_aspect:
        return float(fov_y)
    t = math.tan(math.radians(fov_y) / 2.0) * scene_aspect / aspect
    return min(math.degrees(2.0 * math.atan(t)), MAX_FIT_FOV_Y)


def fit_scene(loaded: LoadedScene, size: tuple[int, int] | None) -> LoadedScene:
    """``loaded`` with its camera's fov_y fitted (``fit_fov_y``) so that an image of
    ``size`` keeps the whole framing of the scene's own render.width x render.height
    (projector-ready framing: ``pbs render --fit``, the walkthrough). ``None`` or the
    scene's own aspect returns ``loaded`` unchanged."""
    if size is None:
        return loaded
    render = loaded.scene.render
    cam = loaded.scene.camera
    fov = fit_fov_y(cam.fov_y, render.width / render.height, size[0] / size[1])
    if fov == cam.fov_y:
        return loaded
    camera = cam.model_copy(update={"fov_y": fov})
    return loaded.with_scene(loaded.scene.model_copy(update={"camera": camera}))
