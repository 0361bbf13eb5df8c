"""Twin of glsl/post/dof.glsl and glsl/passes/dof.frag: thin-lens depth of field
(RTR4 §9.2, the camera), in float64.

A thin lens of aperture diameter A focused at distance z_f images a point at view depth z
as a disc (the circle of confusion). Seen from the lens its angular diameter is
A |z - z_f| / (z z_f) (similar triangles through the lens centre, small angles), so its
radius in pixels of an image of height H and vertical field of view fov_y is

    r(z) = A |z - z_f| / (2 z z_f) * H / (2 tan(fov_y / 2)),

0 on the focus plane, A / (2 z_f) * H / (2 tan(fov_y / 2)) for the background (z -> inf).

The pass scatters each pixel's radiance over its disc, written as a gather: pixel i
averages the samples j of a fixed disc of offsets o_j whose own disc covers it
(|o_j| <= r_j), each weighted by 1 / (pi max(r_j, 1/2)^2), the share of its radiance one
pixel of its disc receives. A sample behind the centre pixel (z_j > z_i) may reach it only
as far as the centre's own disc (r_j capped at r_i), so a blurred background does not
bleed over a sharp object in front of it. The weighted average keeps a uniform image
uniform and an in-focus pixel (r_i = 0 and no nearer disc covering it) exactly itself.
"""

from __future__ import annotations

import math

import numpy as np

MAX_COC = 12.0  # px: the largest radius a pixel's disc may have (the gather's reach)
SAMPLES = 128  # off-centre samples of the gather disc (about one per 3.5 px²)
MIN_RADIUS = 0.5  # px: a disc is never smaller than one pixel in the weight


def gather_offsets(samples: int = SAMPLES, radius: float = MAX_COC) -> np.ndarray:
    """(samples, 2) int offsets: a Vogel (golden-angle) spiral filling the disc of
    ``radius`` evenly, rounded to whole pixels; the centre is not among them. The GLSL
    receives this very list (app/render/post.py), so both sample the same pixels."""
    k = np.arange(samples, dtype=np.float64)
    r = radius * np.sqrt((k + 0.5) / samples)
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    out = np.rint(np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)).astype(np.int64)
    out[np.all(out == 0, axis=-1)] = (1, 0)  # never the centre itself
    return out


def all_offsets(radius: float = MAX_COC) -> np.ndarray:
    """(K, 2) every whole-pixel offset within ``radius`` but the centre (440 for 12 px):
    dof_gather with these is the dense gather the pass's 128 samples approximate."""
    r = math.floor(radius)
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    keep = (xx * xx + yy * yy <= radius * radius) & ~((xx == 0) & (yy == 0))
    return np.stack([xx[keep], yy[keep]], axis=-1)


def pixels_per_radian(fov_y_deg: float, height: int) -> float:
    """H / (2 tan(fov_y / 2)): pixels per unit of tangent at the image centre."""
    return height / (2.0 * math.tan(math.radians(fov_y_deg) / 2.0))


def coc_radius(
    z: np.ndarray, aperture: float, focus: float, scale: float, max_coc: float = MAX_COC
) -> np.ndarray:
    """Circle-of-confusion radius in pixels at view depth z (0 or non-finite: the
    background, z -> inf), clamped to ``max_coc``; ``scale`` from pixels_per_radian."""
    z = np.asarray(z, np.float64)
    far = ~(np.isfinite(z) & (z > 0.0))
    zz = np.where(far, 1.0, z)
    r = np.where(far, aperture / (2.0 * focus), aperture * np.abs(zz - focus) / (2.0 * zz * focus))
    return np.minimum(r * scale, max_coc)


def dof_gather(
    hdr: np.ndarray, depth: np.ndarray, aperture: float, focus: float, scale: float,
    offsets: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """The pass's image from linear HDR (H, W, 3) and view depth (H, W), rows top to
    bottom; samples outside the image are clamped to its edge (the GL's clamp-to-edge)."""
    hdr = np.asarray(hdr, np.float64)
    offsets = gather_offsets() if offsets is None else offsets
    h, w = depth.shape
    zf = np.where(np.isfinite(depth) & (depth > 0.0), depth, np.inf).astype(np.float64)
    r = coc_radius(depth, aperture, focus, scale)
    w_self = 1.0 / (math.pi * np.maximum(r, MIN_RADIUS) ** 2)
    acc = hdr * w_self[..., None]
    total = w_self.copy()
    ys, xs = np.mgrid[0:h, 0:w]
    for dx, dy in offsets:
        # (dx, dy) in GL pixels (y up); image rows run down.
        sy = np.clip(ys - dy, 0, h - 1)
        sx = np.clip(xs + dx, 0, w - 1)
        rj = r[sy, sx]
        rj = np.where(zf[sy, sx] > zf, np.minimum(rj, r), rj)
        reach = math.hypot(dx, dy) <= rj
        wj = np.where(reach, 1.0 / (math.pi * np.maximum(rj, MIN_RADIUS) ** 2), 0.0)
        acc += hdr[sy, sx] * wj[..., None]
        total += wj
    return acc / total[..., None]
