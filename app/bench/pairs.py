"""Exact per-pixel light lists from a read-back G-buffer, and the float64 reference image.

A (pixel, light) pair is *in range* when the light can add anything at the pixel's surface
point: every directional light, and a point or spot light whose centre is closer than its
range (the window ((1 - (d/r)^4)+)^2 of glsl/lights/punctual.glsl is exactly 0 from d = r
on) and, for a spot light, inside its outer cone (the cone factor t^2 is exactly 0 from
the outer angle on). The lists are found in float64 from the G-buffer's float32 view
depth, so they are exact for the positions the GPU reconstructs up to float32 rounding;
a light that float32 rounding would move across its own range boundary adds
((1 - (d/r)^4)+)^2 ~ 1e-13 of its colour there (and as little across its cone's edge).

The floor pass (app/bench/floor.py) loops these lists and nothing else; the reference
(``reference_hdr``) evaluates the float64 twin on the same pairs, since out-of-range lights
add exactly 0 in the twin too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import GBufferData
from app.common.lights import LightType, PunctualLight
from app.common.models import Model, unpack_model_params
from app.reference.constants import PI
from app.reference.illumination import decode_gbuffer, surface_positions
from app.reference.material import brdf_eval, brdf_eval_layered_cos
from app.reference.punctual import light_at

PIXEL_CHUNK = 8192  # pixels per distance block: PIXEL_CHUNK x lights float64 at a time


@dataclass
class LightPairs:
    """Every (covered pixel, light in range) pair, grouped by pixel.

    ``first`` and ``count`` are (H, W), rows top to bottom: pixel (y, x)'s lights are
    ``lights[first[y, x] : first[y, x] + count[y, x]]``, indices into the renderer's light
    list in ascending order (the order of the lighting pass's loop).
    """

    first: np.ndarray  # (H, W) uint32
    count: np.ndarray  # (H, W) uint32
    lights: np.ndarray  # (P,) uint32
    covered: np.ndarray  # (H, W) bool: pixels with a surface

    @property
    def total(self) -> int:
        return int(self.lights.size)

    @property
    def mean_per_covered_pixel(self) -> float:
        """The measured average number of lights that reach a surface pixel."""
        n = int(self.covered.sum())
        return self.total / n if n else 0.0

    def pixel_index(self) -> np.ndarray:
        """(P,) the flat (row-major, top row first) pixel index of each pair."""
        flat = self.count.ravel().astype(np.int64)
        return np.repeat(np.arange(flat.size, dtype=np.int64), flat)


def in_cone_mask(
    p: np.ndarray, centres: np.ndarray, axes: np.ndarray, cos_outer: np.ndarray
) -> np.ndarray:
    """(C, L) bool: p_c lies inside light l's outer cone, cos(angle to the axis) >
    cos_outer (RTR4 eq. 5.18: the cone factor is 0 from there on); cos_outer < -1 for
    point lights, which have no cone."""
    mask = np.ones((len(p), len(centres)), bool)
    cols = np.nonzero(cos_outer >= -1.0)[0]
    if cols.size:
        to_p = p[:, None, :] - centres[None, cols, :]
        dist = np.linalg.norm(to_p, axis=-1)
        along = np.einsum("ijk,jk->ij", to_p, axes[cols])
        mask[:, cols] = along > cos_outer[None, cols] * dist
    return mask


def in_range_mask(p: np.ndarray, centres: np.ndarray, ranges: np.ndarray) -> np.ndarray:
    """(C, L) bool: |p_c - centre_l| < range_l, exactly in float64.

    The squared distances come first from |p|^2 + |c|^2 - 2 p.c (one matrix product), whose
    cancellation error is below 1e-12 of |p|^2 + |c|^2; pairs within that of the boundary
    are decided again from the difference vectors themselves.
    """
    p2 = np.einsum("ij,ij->i", p, p)[:, None]
    c2 = np.einsum("ij,ij->i", centres, centres)[None, :]
    d2 = p2 + c2 - 2.0 * (p @ centres.T)
    r2 = (ranges * ranges)[None, :]
    slack = 1e-12 * (p2 + c2) + 1e-300
    mask = d2 < r2 - slack
    unsure = np.abs(d2 - r2) <= slack
    if np.any(unsure):
        rows, cols = np.nonzero(unsure)
        diff = p[rows] - centres[cols]
        mask[rows, cols] = np.einsum("ij,ij->i", diff, diff) < r2[0, cols]
    return mask


def light_pairs(
    gbuffer: GBufferData, camera: CameraFrame, lights: list[PunctualLight]
) -> LightPairs:
    """The exact per-pixel light lists of a G-buffer (see the module docstring)."""
    covered, p = surface_positions(gbuffer, camera)
    h, w = covered.shape
    local = np.array([i for i, x in enumerate(lights) if x.is_local], np.int64)
    directional = np.array([i for i, x in enumerate(lights) if not x.is_local], np.int64)
    centres = np.array([lights[i].position for i in local], np.float64).reshape(-1, 3)
    ranges = np.array([lights[i].range for i in local], np.float64)
    spot = np.array([lights[i].type == LightType.SPOT for i in local], bool)
    axes = np.array([lights[i].direction for i in local], np.float64).reshape(-1, 3)
    cos_outer = np.array([lights[i].cos_outer for i in local], np.float64)
    per_pixel_lights: list[np.ndarray] = []
    counts = np.zeros(len(p), np.int64)
    for start in range(0, len(p), PIXEL_CHUNK):
        block = p[start : start + PIXEL_CHUNK]
        # Only lights whose range sphere reaches the block's bounding box can be in range
        # (a block is a few image rows, a narrow strip of the scene).
        lo, hi = block.min(axis=0), block.max(axis=0)
        gap = np.maximum(np.maximum(lo - centres, centres - hi), 0.0)
        near = np.nonzero((gap * gap).sum(axis=1) < ranges * ranges)[0]
        ids = np.concatenate([directional, local[near]])
        reach = np.ones((len(block), ids.size), bool)
        if near.size:
            reach[:, directional.size :] = in_range_mask(block, centres[near], ranges[near])
            reach[:, directional.size :] &= in_cone_mask(
                block, centres[near], axes[near], np.where(spot[near], cos_outer[near], -2.0)
            )
        order = np.argsort(ids)  # columns in ascending light order
        rows, k = np.nonzero(reach[:, order])  # row-major: by pixel, then by light
        cols = ids[order][k]
        counts[start : start + len(block)] = np.bincount(rows, minlength=len(block))
        per_pixel_lights.append(cols.astype(np.uint32))
    lights_flat = np.concatenate(per_pixel_lights) if per_pixel_lights else np.zeros(0, np.uint32)
    count = np.zeros((h, w), np.int64)
    count[covered] = counts
    first = np.concatenate([[0], np.cumsum(count.ravel())[:-1]]).reshape(h, w)
    return LightPairs(first.astype(np.uint32), count.astype(np.uint32), lights_flat, covered)


def reference_hdr(
    gbuffer: GBufferData,
    camera: CameraFrame,
    lights: list[PunctualLight],
    background: np.ndarray,
    models: list[Model],
    table: np.ndarray,
    pairs: LightPairs | None = None,
    ms_table: np.ndarray | None = None,
) -> np.ndarray:
    """The lighting pass's image in float64, (H, W, 3): app.reference.illumination's
    shade_gbuffer (sanitising included), restricted to the in-range pairs when ``pairs`` is
    given (the lights left out add exactly 0), and with a chosen multiple-scattering table."""
    g = decode_gbuffer(gbuffer, camera)  # as the lighting pass, sanitising included
    covered, p, ids = g.covered, g.p, g.material_id
    h, w = covered.shape
    out = np.broadcast_to(np.asarray(background, np.float64), (h, w, 3)).copy()
    Lo = np.zeros((len(p), 3))
    # Pairs as (covered-pixel index, light index), grouped by light.
    if pairs is None:
        pair_pixel = None
    else:
        flat_to_covered = np.full(h * w, -1, np.int64)
        flat_to_covered[covered.ravel()] = np.arange(len(p))
        pair_pixel = flat_to_covered[pairs.pixel_index()]
        order = np.argsort(pairs.lights, kind="stable")
        pair_pixel = pair_pixel[order]
        bounds = np.searchsorted(pairs.lights[order], np.arange(len(lights) + 1))
    for row in np.unique(ids):
        model = models[int(table[row, 3, 0])]
        params = unpack_model_params(table[row])
        in_row = ids == row
        for j, light in enumerate(lights):
            if pair_pixel is None:
                sel = np.nonzero(in_row)[0]
            else:
                sel = pair_pixel[bounds[j] : bounds[j + 1]]
                sel = sel[in_row[sel]]
            if sel.size == 0:
                continue
            point = g.point(sel, params)
            c_light, l = light_at(light, p[sel])
            n = point.n
            if point.nc is not None and model.clearcoat != "none":  # each layer's own cosine
                f_cos = brdf_eval_layered_cos(point, model, l)
                Lo[sel] += f_cos * c_light
                continue
            NoL = np.einsum("ij,ij->i", n, l)
            lit = NoL > 0.0
            if not np.any(lit):
                continue
            f = brdf_eval(point, model, l, ms_table)
            Lo[sel] += np.where(lit[:, None], f * c_light * NoL[:, None], 0.0)
    out[covered] = PI * Lo
    return out
