"""Twin of glsl/passes/lighting.frag: the illumination sum over a read-back G-buffer.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (seed section 4), in float64, from
the very G-buffer values the GPU shaded, so the comparison isolates the lighting pass.
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot, normalize
from app.reference.constants import PI
from app.reference.encoding import oct_decode
from app.reference.material import Surface, brdf_standard
from app.reference.position import reconstruct_position
from app.reference.punctual import light_at
from app.scene.camera import CameraFrame


def illumination_sum(
    s: Surface, n: np.ndarray, p: np.ndarray, v: np.ndarray, lights: list[dict]
) -> np.ndarray:
    """Seed section 4: pi sum_i f(l_i, v) c_light_i (n.l_i)+ at points ``p`` (..., 3)."""
    Lo = np.zeros(np.shape(p), np.float64)
    for light in lights:
        c_light, l = light_at(light, p)
        NoL = dot(n, l)
        lit = NoL > 0.0
        if not np.any(lit):
            continue
        f = brdf_standard(s, n, l, v)
        Lo += np.where(lit[..., None], f * c_light * NoL[..., None], 0.0)
    return PI * Lo


def pixel_ndc(height: int, width: int) -> np.ndarray:
    """NDC (x, y) of pixel centres, (H, W, 2), row 0 at the top of the image."""
    x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    y = 1.0 - (np.arange(height) + 0.5) / height * 2.0
    return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1)


def shade_gbuffer(
    albedo: np.ndarray,
    normal: np.ndarray,
    depth: np.ndarray,
    camera: CameraFrame,
    lights: list[dict],
    background: np.ndarray,
) -> np.ndarray:
    """The HDR image the lighting pass should produce, (H, W, 3) float64."""
    albedo = np.asarray(albedo, np.float64)
    normal = np.asarray(normal, np.float64)
    covered = depth > 0.0
    out = np.broadcast_to(np.asarray(background, np.float64), (*albedo.shape[:2], 3)).copy()
    p = reconstruct_position(
        pixel_ndc(*depth.shape)[covered], depth[covered], camera.position,
        camera.camera_to_world, camera.tan_half_fov,
    )  # fmt: skip
    a, b = albedo[covered], normal[covered]
    s = Surface(a[:, :3], a[:, 3], b[:, 2], b[:, 3])
    n = oct_decode(b[:, :2])
    v = normalize(camera.position - p)
    out[covered] = illumination_sum(s, n, p, v, lights)
    return out
