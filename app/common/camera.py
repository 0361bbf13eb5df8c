"""What the lighting pass (and its twin) needs of a camera to turn a depth back into a world
position (glsl/common/position.glsl)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CameraFrame:
    """What the lighting pass needs to turn a depth value back into a world position."""

    position: np.ndarray  # (3,) world
    camera_to_world: np.ndarray  # (3, 3) rotation, columns = camera right, up, back
    tan_half_fov: tuple[float, float]  # (tan(fov_y/2) * aspect, tan(fov_y/2))
    near: float
    far: float
    # The projection's sub-pixel jitter as an NDC offset (antialiasing = "jitter",
    # app/render/antialias.py); where it is not zero, camera_to_world is the rotation times
    # the shear that moves each pixel's ray by the same offset, no longer orthonormal.
    jitter: tuple[float, float] = (0.0, 0.0)
