"""Twin of glsl/common/position.glsl: world positions from the G-buffer's view depth."""

from __future__ import annotations

import numpy as np


def reconstruct_position(
    ndc_xy: np.ndarray,
    z: np.ndarray,
    camera_pos: np.ndarray,
    camera_to_world: np.ndarray,
    tan_half_fov: np.ndarray,
) -> np.ndarray:
    """camera + z R (ndc.x tan_x, ndc.y tan_y, -1), broadcasting over pixels."""
    ndc_xy = np.asarray(ndc_xy, np.float64)
    local = np.concatenate(
        [ndc_xy * np.asarray(tan_half_fov, np.float64), -np.ones((*ndc_xy.shape[:-1], 1))],
        axis=-1,
    )
    ray = local @ np.asarray(camera_to_world, np.float64).T
    return np.asarray(camera_pos, np.float64) + np.asarray(z, np.float64)[..., None] * ray
