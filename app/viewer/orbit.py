"""Orbit, pan and zoom: the viewer's camera controls as pure functions of a ``Camera``.

The camera orbits its target on a sphere: yaw about the world up axis (+Y), pitch towards
it, both in degrees, and a distance. A drag of the whole window height turns the camera by
``ORBIT_DEGREES_PER_HEIGHT``; a pan moves the target in the view plane so that the point
under the cursor stays under it (at the target's depth); a wheel step scales the distance
by ``ZOOM_STEP``. The result is a new, validated ``Camera``: what the scene file would
hold, so a saved scene shows exactly the view on screen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from app.scene.model import Camera

ORBIT_DEGREES_PER_HEIGHT = 180.0  # a drag across the window's height turns half a circle
MAX_PITCH = 89.0  # degrees: the view never reaches the up axis, where yaw is undefined
ZOOM_STEP = 0.9  # a wheel step towards the target multiplies the distance by this
MIN_DISTANCE = 1e-3  # metres


@dataclass(frozen=True)
class Orbit:
    """A camera as target, distance, yaw and pitch (degrees)."""

    target: np.ndarray
    distance: float
    yaw: float
    pitch: float

    @classmethod
    def of(cls, camera: Camera) -> Orbit:
        target = np.asarray(camera.target, np.float64)
        offset = np.asarray(camera.position, np.float64) - target
        distance = float(np.linalg.norm(offset))
        pitch = math.degrees(math.asin(np.clip(offset[1] / distance, -1.0, 1.0)))
        yaw = math.degrees(math.atan2(offset[0], offset[2]))
        return cls(target, distance, yaw, pitch)

    def position(self) -> np.ndarray:
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        direction = np.array(
            [math.cos(pitch) * math.sin(yaw), math.sin(pitch), math.cos(pitch) * math.cos(yaw)]
        )
        return self.target + self.distance * direction

    def camera(self, base: Camera) -> Camera:
        """``base`` with this orbit's position and target and +Y up (the lens unchanged)."""
        return Camera.model_validate(
            {
                **base.model_dump(),
                "position": [float(x) for x in self.position()],
                "target": [float(x) for x in self.target],
                "up": [0.0, 1.0, 0.0],
            }
        )


def orbit(camera: Camera, dx: float, dy: float, height: int) -> Camera:
    """Turn around the target by a drag of (dx, dy) pixels in a window ``height`` tall
    (right: the camera moves left around the target, as in Blender and the Khronos
    viewer; down: it rises)."""
    o = Orbit.of(camera)
    scale = ORBIT_DEGREES_PER_HEIGHT / max(height, 1)
    pitch = float(np.clip(o.pitch + dy * scale, -MAX_PITCH, MAX_PITCH))
    return Orbit(o.target, o.distance, o.yaw - dx * scale, pitch).camera(camera)


def pan(camera: Camera, dx: float, dy: float, height: int, fov_y: float | None = None) -> Camera:
    """Slide camera and target in the view plane by a drag of (dx, dy) pixels: the point
    at the target's depth under the cursor follows it. ``fov_y``: the vertical field of
    view the image is shown with, where it is not the camera's (the viewer's sensor fit
    widens it for a narrow image area); the camera's own is kept either way."""
    position = np.asarray(camera.position, np.float64)
    target = np.asarray(camera.target, np.float64)
    forward = target - position
    distance = float(np.linalg.norm(forward))
    forward /= distance
    right = np.cross(forward, np.asarray(camera.up, np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    shown = camera.fov_y if fov_y is None else fov_y
    metres_per_pixel = 2.0 * distance * math.tan(math.radians(shown) / 2.0) / height
    shift = (-dx * right + dy * up) * metres_per_pixel
    return Camera.model_validate(
        {
            **camera.model_dump(),
            "position": [float(x) for x in position + shift],
            "target": [float(x) for x in target + shift],
        }
    )


def zoom(camera: Camera, steps: float) -> Camera:
    """Move towards the target by ``steps`` wheel steps (negative: away)."""
    o = Orbit.of(camera)
    distance = max(o.distance * ZOOM_STEP**steps, MIN_DISTANCE)
    return Orbit(o.target, distance, o.yaw, o.pitch).camera(camera)


def frame(camera: Camera, centre: np.ndarray, radius: float) -> Camera:
    """Look at a bounding sphere from the current direction, at the distance where it just
    fills the narrower field of view (square images assumed: the vertical one)."""
    o = Orbit.of(camera)
    half = math.radians(camera.fov_y) / 2.0
    distance = max(radius / math.sin(half), MIN_DISTANCE) * 1.05
    return Orbit(np.asarray(centre, np.float64), distance, o.yaw, o.pitch).camera(camera)
