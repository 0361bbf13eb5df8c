"""The mip levels a still frame samples of a model's textures (texture streaming, as
engines do it: the finest level a mesh needs, from its UV density and the camera).

A one-view render (`pbs render` of a model file) knows its camera before it decodes a
texture: the framing camera depends on the geometry alone. ``sampled_uv_lods`` rasterizes
the triangles the G-buffer pass draws (back faces of one-sided meshes culled, as the GL
culls them) at the image's pixel centres with a depth buffer, and over every pixel centre
a textured triangle covers and no nearer triangle hides, takes the level of detail the
GL's sampler computes there (OpenGL 4.6 §8.14.1): log2 of the scale factor rho, the
texture coordinates' derivatives along the window's x and y (in texels). It returns
the texture-size-free part per visible pixel, ``log2 max(|du/dx|, |dv/dx|, |du/dy|, |dv/dy|)``
in UV units (``sampled_uv_lods``); a texture of ``N`` texels a side samples no level finer
than ``floor(lod + log2 N)`` at a pixel, and the levels no pixel samples need not be
decoded, built nor uploaded (``reduced_levels``: nor the levels that a few pixels blend
in by a small weight, ``MAX_SKIPPED_WEIGHT`` and ``SKIPPED_SHARE``).

The per-pixel rho here is the "max of absolute values" form the specification allows as
its lower approximation (llvmpipe's default; the exact length of each derivative vector is
at most sqrt 2 more), so the bound holds for either. The derivatives are the analytic ones
of the perspective-correct interpolation at the pixel centre, where the GL takes finite
differences across a 2x2 quad (at a few hundred pixels a side, a part in a thousand):
``LOD_MARGIN`` covers that.

Visibility at pixel centres is what the G-buffer keeps: a triangle hidden behind another
is drawn and sampled but its texels never reach the image (the helmet's interior
triangles with shrunken UVs sample level 0 where nothing sees them). Ties in depth count
as visible (both triangles' levels are taken), and a pixel on a triangle's edge counts
as covered by both triangles that share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Levels of detail a texture's bound keeps in hand (module docstring): the finite
# differences of a 2x2 quad against the derivative at a pixel centre.
LOD_MARGIN = 0.01
# What skipping the levels below n may take from the frame, over its visible textured
# pixel centres: where a pixel's LOD lies in [n - 1, n), the GL blends level n - 1 by
# n - LOD, and starting at level n it reads level n alone. Skipped: at most
# MAX_SKIPPED_WEIGHT of any one pixel, and at most SKIPPED_SHARE of the pixels' summed
# weight (a mean over the frame, as the accuracy targets' mean error is). The helmet at
# 480x480: 104 of its 100k textured pixels lie in [0.91, 1), 3.2 pixels' worth of level 0;
# WaterBottle: 17 of 64k in [0.877, 1), 1.8 pixels' worth (docs/filtering.md).
MAX_SKIPPED_WEIGHT = 0.25
SKIPPED_SHARE = 1e-3
# The reductions a JPEG decodes directly (libjpeg's DCT scaling: 1/2, 1/4, 1/8).
MAX_REDUCTION = 3


@dataclass(frozen=True)
class ViewTriangles:
    """One drawn primitive for the bound: world positions (N, 3), TEXCOORD_0 (N, 2) or
    None (untextured: it hides, nothing of it is sampled), faces (M, 3), and whether both
    faces are drawn (a double-sided material, or a mirrored world matrix's flipped
    winding: ``mirrored``)."""

    positions: np.ndarray
    uv: np.ndarray | None
    faces: np.ndarray
    two_sided: bool
    mirrored: bool = False


def sampled_uv_lods(
    triangles: list[ViewTriangles], camera: dict, size: tuple[int, int]
) -> np.ndarray:
    """The log2 max-abs UV derivative at each visible pixel centre of the textured
    triangles (module docstring), in no order: empty where none is visible, ``[-inf]``
    where the bound cannot be taken (a vertex at or behind the near plane)."""
    width, height = size
    eye = np.asarray(camera["position"], np.float64)
    forward = np.asarray(camera["target"], np.float64) - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(camera["up"], np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_y = math.tan(math.radians(camera["fov_y"]) / 2.0)
    tan_x = tan_y * width / height
    near = float(camera.get("near", 0.0))
    screens, depths, uvs, keep = [], [], [], []
    offset = 0
    for tri in triangles:
        rel = tri.positions - eye
        z = rel @ forward
        if np.any(z[tri.faces] <= max(near, 0.0) * 0.999):
            return np.array([-math.inf])
        with np.errstate(divide="ignore", invalid="ignore"):  # vertices no face uses
            sx = ((rel @ right) / z / tan_x + 1.0) * 0.5 * width
            sy = ((rel @ up) / z / tan_y + 1.0) * 0.5 * height
        screens.append(np.stack([sx, sy], axis=1))
        depths.append(z)
        uvs.append(tri.uv if tri.uv is not None else np.full((len(z), 2), np.nan))
        faces = tri.faces + offset
        e1, e2 = (screens[-1][tri.faces[:, k]] - screens[-1][tri.faces[:, 0]] for k in (1, 2))
        area = e1[:, 0] * e2[:, 1] - e2[:, 0] * e1[:, 1]  # > 0: counter-clockwise, y up
        drawn = np.ones(len(faces), bool) if tri.two_sided else (area > 0) != tri.mirrored
        keep.append(faces[drawn & (area != 0)])
        offset += len(z)
    if not keep:
        return np.zeros(0)
    screen = np.concatenate(screens)
    with np.errstate(divide="ignore"):
        inv_z = 1.0 / np.concatenate(depths)
    uv = np.concatenate(uvs)
    faces = np.concatenate(keep)
    worst = visible_derivatives(screen, inv_z, uv, faces, width, height)
    with np.errstate(divide="ignore"):
        return np.log2(worst)


def visible_derivatives(
    screen: np.ndarray,
    inv_z: np.ndarray,
    uv: np.ndarray,
    faces: np.ndarray,
    width: int,
    height: int,
) -> np.ndarray:
    """``sampled_uv_lods``' raster: every drawn face's covered pixel centres (scanlines:
    per row of its box the span between its edges' crossings of the row's centre line,
    edges included), the nearest 1/z per pixel, then at the covered centres no nearer
    face hides the largest absolute UV derivative per window pixel (one value per
    visible textured pixel centre; a pixel shared by faces at one depth, each)."""
    s = screen[faces]  # (M, 3, 2)
    # (the least and the most of three as two element-wise steps: numpy's reduction along
    # a short last axis loops per row)
    y0, y1, y2 = s[:, 0, 1], s[:, 1, 1], s[:, 2, 1]
    row_lo = np.ceil(np.minimum(np.minimum(y0, y1), y2) - 0.5)
    row_hi = np.floor(np.maximum(np.maximum(y0, y1), y2) - 0.5)
    row_lo = np.maximum(row_lo, 0).astype(np.int64)
    row_hi = np.minimum(row_hi, height - 1).astype(np.int64)
    rows = np.maximum(row_hi - row_lo + 1, 0)
    owner = np.repeat(np.arange(len(faces)), rows)  # one entry per (face, row)
    first = np.cumsum(rows) - rows
    row = row_lo[owner] + np.arange(len(owner)) - first[owner]
    centre = row + 0.5
    # Per face and edge as contiguous arrays (rows: edge e runs from corner e to corner
    # e + 1), each gathered once per entry: gathers from the (M, 3, 2) corners were most
    # of the raster's time.
    sx, sy = s[:, :, 0].T, s[:, :, 1].T  # (3, M)
    ex, ey = sx[[1, 2, 0]], sy[[1, 2, 0]]  # each edge's end
    dx, dy = ex - sx, ey - sy
    edge_lo, edge_hi = np.minimum(sy, ey), np.maximum(sy, ey)
    left = np.full(len(owner), np.inf)
    right = np.full(len(owner), -np.inf)
    for e in range(3):
        lo, hi = edge_lo[e][owner], edge_hi[e][owner]
        crosses = (lo <= centre) & (centre <= hi) & (hi > lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = sx[e][owner] + (centre - sy[e][owner]) / dy[e][owner] * dx[e][owner]
        left = np.where(crosses, np.minimum(left, x), left)
        right = np.where(crosses, np.maximum(right, x), right)
    col_lo = np.maximum(np.ceil(left - 0.5), 0)
    col_hi = np.minimum(np.floor(right - 0.5), width - 1)
    spans = np.where(np.isfinite(left), np.maximum(col_hi - col_lo + 1, 0), 0).astype(np.int64)
    entry = np.repeat(np.arange(len(owner)), spans)  # one per covered pixel centre
    if len(entry) == 0:
        return np.zeros(0)
    start = np.cumsum(spans) - spans
    col = col_lo.astype(np.int64)[entry] + np.arange(len(entry)) - start[entry]
    face = owner[entry]
    row = row[entry]
    px, py = col + 0.5, row + 0.5
    # Per face, 1/z, u/z and v/z as affine functions of the window position: the value
    # at vertex 0 plus the gradient (f1 - f0) grad a + (f2 - f0) grad b, where
    # (a, b) = M^-1 (p - s0), M = [s1 - s0, s2 - s0], weigh vertices 1 and 2.
    e1, e2 = s[:, 1] - s[:, 0], s[:, 2] - s[:, 0]
    det = e1[:, 0] * e2[:, 1] - e2[:, 0] * e1[:, 1]
    grad_a = np.stack([e2[:, 1], -e2[:, 0]], axis=1) / det[:, None]
    grad_b = np.stack([-e1[:, 1], e1[:, 0]], axis=1) / det[:, None]
    w_z = inv_z[faces]  # (M, 3)
    values = np.concatenate([w_z[..., None], uv[faces] * w_z[..., None]], axis=2)  # (M, 3, 3)
    grad = (values[:, 1] - values[:, 0])[:, :, None] * grad_a[:, None, :] + (
        values[:, 2] - values[:, 0]
    )[:, :, None] * grad_b[:, None, :]  # (M, 3 values, 2 axes)
    base = values[:, 0] - np.einsum("mva,ma->mv", grad, s[:, 0])
    # Each value's base and gradients as contiguous per-face arrays, gathered per pixel.
    base_of = [np.ascontiguousarray(base[:, v]) for v in range(3)]
    grad_of = [[np.ascontiguousarray(grad[:, v, a]) for a in range(2)] for v in range(3)]
    depth = base_of[0][face] + grad_of[0][0][face] * px + grad_of[0][1][face] * py
    pixel = row * width + col
    nearest = np.full(width * height, -np.inf)
    np.maximum.at(nearest, pixel, depth)
    seen = depth >= nearest[pixel] * (1.0 - 1e-6)
    seen &= ~np.isnan(base_of[1][face])  # untextured faces hide, nothing of them is sampled
    if not np.any(seen):
        return np.zeros(0)
    face, px, py, depth = face[seen], px[seen], py[seen], depth[seen]
    # perspective-correct u and v at the pixel centre, then per window axis
    # d uv = (d(uv/z) - uv d(1/z)) / (1/z); the largest of the four
    u = (base_of[1][face] + grad_of[1][0][face] * px + grad_of[1][1][face] * py) / depth
    v = (base_of[2][face] + grad_of[2][0][face] * px + grad_of[2][1][face] * py) / depth
    worst = np.zeros(len(depth))
    for axis in (0, 1):
        dz = grad_of[0][axis][face]
        du = np.abs((grad_of[1][axis][face] - u * dz) / depth)
        dv = np.abs((grad_of[2][axis][face] - v * dz) / depth)
        worst = np.maximum(worst, np.maximum(du, dv))
    return worst


def reduced_levels(uv_lods: np.ndarray, width: int, height: int) -> int:
    """How many of a ``width`` x ``height`` texture's finest levels a frame whose visible
    pixels sample at ``uv_lods`` (``sampled_uv_lods``) may start without: the most n, at
    most ``MAX_REDUCTION`` and no more than both sides divide by (level k of the reduced
    texture is then level k + n of the full one, the GL's sizes), for which the levels
    below n carry at most ``MAX_SKIPPED_WEIGHT`` of any pixel's trilinear blend (its LOD
    ``uv_lod + log2 min side`` less ``LOD_MARGIN``, the GL's finite differences) and
    ``SKIPPED_SHARE`` of the frame's (the LODs as they are: the margin bounds one pixel's
    error, it is no blend every pixel makes)."""
    if len(uv_lods) == 0:  # nothing textured is seen
        n = MAX_REDUCTION
    elif not np.isfinite(uv_lods).all():  # no bound (or a magnification beyond any)
        return 0
    else:
        lod = uv_lods + math.log2(max(min(width, height), 1))
        least = float(lod.min()) - LOD_MARGIN  # the most any pixel may blend: the margin's
        n = 0
        for k in range(MAX_REDUCTION, 0, -1):
            taken = np.clip(k - lod, 0.0, 1.0).sum()  # the pixels' blend of levels < k
            if k - least <= MAX_SKIPPED_WEIGHT and taken <= SKIPPED_SHARE * len(lod):
                n = k
                break
    while n and (width % (1 << n) or height % (1 << n)):
        n -= 1
    return n
