"""Twin of glsl/passes/lighting.frag: the illumination sum over a read-back G-buffer.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (seed section 4), in float64, from
the very G-buffer values the GPU shaded, so the comparison isolates the lighting pass.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from app.reference._vec import dot, normalize
from app.reference.constants import PI
from app.reference.encoding import oct_decode
from app.reference.material import Surface, brdf_eval, sanitize_direction, sanitize_surface
from app.reference.model import Model, ModelParams, unpack_model_params
from app.reference.position import reconstruct_position
from app.reference.punctual import light_at
from app.scene.camera import CameraFrame

if TYPE_CHECKING:
    from app.render.gbuffer import GBufferData


def illumination_sum(
    s: Surface,
    params: ModelParams,
    model: Model,
    n: np.ndarray,
    t: np.ndarray,
    p: np.ndarray,
    v: np.ndarray,
    lights: list[dict],
    terms: str = "all",
) -> np.ndarray:
    """Seed section 4: pi sum_i f(l_i, v) c_light_i (n.l_i)+ at points ``p`` (..., 3);
    ``terms`` as in ``brdf_eval``."""
    Lo = np.zeros(np.shape(p), np.float64)
    for light in lights:
        c_light, l = light_at(light, p)
        NoL = dot(n, l)
        lit = NoL > 0.0
        if not np.any(lit):
            continue
        f = brdf_eval(s, params, model, n, t, l, v, terms=terms)
        Lo += np.where(lit[..., None], f * c_light * NoL[..., None], 0.0)
    return PI * Lo


def pixel_ndc(height: int, width: int) -> np.ndarray:
    """NDC (x, y) of pixel centres, (H, W, 2), row 0 at the top of the image."""
    x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    y = 1.0 - (np.arange(height) + 0.5) / height * 2.0
    return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1)


def shade_gbuffer(
    gbuffer: GBufferData,
    camera: CameraFrame,
    lights: list[dict],
    background: np.ndarray,
    models: list[Model],
    table: np.ndarray,
    terms: str = "all",
) -> np.ndarray:
    """The HDR image the lighting pass should produce, (H, W, 3) float64 (``terms``: the
    scene's render.terms).

    ``table`` is the material table as packed for the GPU ((M, 4, 4) float32, whose row
    [3][0] is the material's index into ``models``); each pixel's row is its material id.
    """
    albedo = np.asarray(gbuffer.albedo, np.float64)
    normal = np.asarray(gbuffer.normal, np.float64)
    tangent = np.asarray(gbuffer.tangent, np.float64)
    depth = gbuffer.depth
    covered = np.isfinite(depth) & (depth > 0.0)
    out = np.broadcast_to(np.asarray(background, np.float64), (*albedo.shape[:2], 3)).copy()
    p = reconstruct_position(
        pixel_ndc(*depth.shape)[covered], depth[covered], camera.position,
        camera.camera_to_world, camera.tan_half_fov,
    )  # fmt: skip
    a, b, c = albedo[covered], normal[covered], tangent[covered]
    ids = c[:, 3].astype(np.int64)
    shaded = np.zeros((len(ids), 3))
    for row in np.unique(ids):
        sel = ids == row
        s = sanitize_surface(Surface(a[sel, :3], a[sel, 3], b[sel, 2], b[sel, 3], c[sel, 2]))
        t = oct_decode(c[sel, :2])
        v = normalize(camera.position - p[sel])
        n = sanitize_direction(oct_decode(b[sel, :2]), v)
        model = models[int(table[row, 3, 0])]
        params = unpack_model_params(table[row])
        shaded[sel] = illumination_sum(s, params, model, n, t, p[sel], v, lights, terms)
    out[covered] = shaded
    return out
