"""Twin of glsl/lights/tiles.glsl: the tiled culler's per-tile decisions, in float64.

Every function broadcasts over its arguments (a tile per element, a light per element, or
both), so a whole frame's (tile, light) decisions come out of one call. The bin functions
work on whole numbers and are exact; the geometric tests differ from the GLSL only by its
float32 rounding, which the culler's range margin (app/render/culling.py) absorbs. The
GLSL's pre-test of the cone stage (``cone_reaches_span``) only spares work and changes no
decision, so it has no twin here.
"""

from __future__ import annotations

import numpy as np

DEPTH_BINS = 32  # bits of a tile's depth mask (Harada et al. 2012, "2.5D culling")


def depth_bin_scale(z_min: np.ndarray, z_max: np.ndarray) -> np.ndarray:
    """Bins per metre of a tile's depth slab: DEPTH_BINS / (z_max - z_min), with a floor on
    the width so that a tile of one depth (a wall seen head-on) still has a finite scale."""
    width = np.maximum(np.asarray(z_max, np.float64) - z_min, 1e-20)
    return DEPTH_BINS / width


def depth_bin(z: np.ndarray, z_min: np.ndarray, bin_scale: np.ndarray) -> np.ndarray:
    """Harada et al. 2012: the bin, 0 ... DEPTH_BINS - 1, of view depth ``z`` in a slab
    split into DEPTH_BINS equal slices from ``z_min``; depths outside clamp to the ends."""
    x = (np.asarray(z, np.float64) - z_min) * bin_scale
    return np.clip(x, 0.0, DEPTH_BINS - 1).astype(np.int64)


def bin_range_mask(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Bits ``lo`` ... ``hi`` (inclusive, 0 <= lo <= hi < 32) set, as uint32."""
    lo = np.asarray(lo, np.int64)
    hi = np.asarray(hi, np.int64)
    ones = np.uint64(0xFFFFFFFF)
    span = (ones >> (31 - (hi - lo)).astype(np.uint64)) << lo.astype(np.uint64)
    return (span & ones).astype(np.uint32)


def tile_depth_mask(z: np.ndarray, z_min: float, z_max: float) -> int:
    """The depth mask of one tile: bit b set when a surface depth of ``z`` (the tile's
    covered pixels) falls in bin b of the slab [z_min, z_max]."""
    bins = depth_bin(z, z_min, depth_bin_scale(z_min, z_max))
    return int(np.bitwise_or.reduce(np.left_shift(1, bins), initial=0))


def lowest_bit(mask: np.ndarray) -> np.ndarray:
    """Index of the lowest set bit of a non-zero uint32 mask."""
    m = np.asarray(mask, np.int64)
    return np.log2(m & -m).astype(np.int64)


def highest_bit(mask: np.ndarray) -> np.ndarray:
    """Index of the highest set bit of a non-zero uint32 mask."""
    m = np.asarray(mask, np.int64)
    return np.floor(np.log2(m)).astype(np.int64)


def tile_planes_reach(
    c: np.ndarray,
    r: np.ndarray,
    ndc_min: np.ndarray,
    ndc_max: np.ndarray,
    tan_half_fov: np.ndarray,
    z_min: np.ndarray,
    z_max: np.ndarray,
) -> np.ndarray:
    """Harada et al. 2012 ("Forward+"): a sphere (view-space centre ``c``, radius ``r``)
    passes unless it lies wholly outside the depth slab or one of the four side planes of
    the tile's frustum, each tested on its own (so a sphere off a corner may pass)."""
    c = np.asarray(c, np.float64)
    d = -c[..., 2]
    k_min = np.asarray(ndc_min, np.float64) * tan_half_fov
    k_max = np.asarray(ndc_max, np.float64) * tan_half_fov
    ok = (d + r >= z_min) & (d - r <= z_max)
    for axis in (0, 1):
        kn, kx = k_min[..., axis], k_max[..., axis]
        ok &= c[..., axis] - kn * d >= -r * np.sqrt(1.0 + kn * kn)
        ok &= kx * d - c[..., axis] >= -r * np.sqrt(1.0 + kx * kx)
    return ok


def tile_box(
    ndc_min: np.ndarray,
    ndc_max: np.ndarray,
    tan_half_fov: np.ndarray,
    z_lo: np.ndarray,
    z_hi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The view-space bounding box (lo, hi), in (x, y, depth), of the tile's frustum
    between depths ``z_lo`` and ``z_hi``: x = k depth over the slab, so each side of the
    box is at z_lo or at z_hi."""
    z_lo = np.asarray(z_lo, np.float64)[..., None]
    z_hi = np.asarray(z_hi, np.float64)[..., None]
    k_min = np.asarray(ndc_min, np.float64) * tan_half_fov
    k_max = np.asarray(ndc_max, np.float64) * tan_half_fov
    lo = np.concatenate([np.minimum(k_min * z_lo, k_min * z_hi), z_lo], axis=-1)
    hi = np.concatenate([np.maximum(k_max * z_lo, k_max * z_hi), z_hi], axis=-1)
    return lo, hi


def tile_box_reach(
    c: np.ndarray,
    r: np.ndarray,
    ndc_min: np.ndarray,
    ndc_max: np.ndarray,
    tan_half_fov: np.ndarray,
    z_lo: np.ndarray,
    z_hi: np.ndarray,
) -> np.ndarray:
    """Arvo 1990, "A simple method for box-sphere intersection testing": does the sphere
    reach the view-space bounding box of the tile's frustum between depths ``z_lo`` and
    ``z_hi``? Exact distance to the box, so unlike the planes it is tight at corners."""
    lo, hi = tile_box(ndc_min, ndc_max, tan_half_fov, z_lo, z_hi)
    q = np.asarray(c, np.float64) * np.array([1.0, 1.0, -1.0])
    gap = np.maximum(np.maximum(lo - q, q - hi), 0.0)
    return np.sum(gap * gap, axis=-1) <= np.square(r)


def cone_reaches_sphere(
    a: np.ndarray,
    u: np.ndarray,
    cos_a: np.ndarray,
    sin_a: np.ndarray,
    length: np.ndarray,
    q: np.ndarray,
    rho: np.ndarray,
) -> np.ndarray:
    """Wronski 2017, "Cull that cone!": does the cone (apex ``a``, unit axis ``u``, outer
    half-angle cosine/sine, ``length``) reach the sphere (centre ``q``, radius ``rho``)?
    Conservative behind the apex, where the side distance underestimates the true one."""
    v = np.asarray(q, np.float64) - np.asarray(a, np.float64)
    along = np.sum(v * u, axis=-1)
    perp = np.sqrt(np.maximum(np.sum(v * v, axis=-1) - along * along, 0.0))
    side = cos_a * perp - along * sin_a
    return (side <= rho) & (along <= rho + length) & (along >= -rho)


def cone_reaches_tile(
    c: np.ndarray,
    r: np.ndarray,
    u: np.ndarray,
    cos_a: np.ndarray,
    sin_a: np.ndarray,
    ndc_min: np.ndarray,
    ndc_max: np.ndarray,
    tan_half_fov: np.ndarray,
    z_lo: np.ndarray,
    z_hi: np.ndarray,
) -> np.ndarray:
    """A spot light's cone reaches the bounding sphere (grown by 1e-4) of the tile
    frustum's view-space box between ``z_lo`` and ``z_hi``, in (x, y, depth) coordinates."""
    c = np.asarray(c, np.float64)
    u = np.asarray(u, np.float64)
    lo, hi = tile_box(ndc_min, ndc_max, tan_half_fov, z_lo, z_hi)
    rho = 0.5 * np.linalg.norm(hi - lo, axis=-1) * (1.0 + 1e-4)
    flip = np.array([1.0, 1.0, -1.0])
    return cone_reaches_sphere(c * flip, u * flip, cos_a, sin_a, r, 0.5 * (lo + hi), rho)


def light_reaches_tile(
    c: np.ndarray,
    r: np.ndarray,
    spot: np.ndarray,
    ndc_min: np.ndarray,
    ndc_max: np.ndarray,
    tan_half_fov: np.ndarray,
    z_min: np.ndarray,
    z_max: np.ndarray,
    depth_mask: np.ndarray,
) -> np.ndarray:
    """2.5D culling (Harada et al. 2012) with a box test: the sphere's depth extent
    [d - r, d + r] must cover an occupied bin of the tile's depth mask; then it must reach
    the tile frustum's box between the nearest and the farthest of those bins (plus a
    float32 allowance) and pass the four side planes; a spot light's cone (``spot``: axis,
    cos outer; cos < -1 for point lights) must reach the bounding sphere of one of those
    bins' boxes."""
    c = np.asarray(c, np.float64)
    spot = np.asarray(spot, np.float64)
    d = -c[..., 2]
    z_min = np.asarray(z_min, np.float64)
    z_max = np.asarray(z_max, np.float64)
    scale = depth_bin_scale(z_min, z_max)
    near = depth_bin(d - r, z_min, scale)
    far = depth_bin(d + r, z_min, scale)
    hits = np.asarray(depth_mask, np.uint32) & bin_range_mask(near, far)
    hit = (hits != 0) & (d + r >= z_min) & (d - r <= z_max)
    safe = np.where(hit, hits, 1)
    slack = Z_SLACK * z_max
    z_lo = z_min + lowest_bit(safe) / scale - slack
    z_hi = z_min + (highest_bit(safe) + 1) / scale + slack
    cos_a = spot[..., 3]
    sin_a = np.sqrt(np.maximum(1.0 - cos_a * cos_a, 0.0))
    # The cone against each occupied slice's box on its own (one sphere around them all
    # would span the tile's whole depth range).
    cone = np.broadcast_to(cos_a < -1.0, np.broadcast(hit, cos_a).shape).copy()
    for b in range(DEPTH_BINS):
        occupied = (safe >> np.uint32(b)) & 1 != 0
        lo = z_min + b / scale - slack
        hi = z_min + (b + 1) / scale + slack
        cone |= (
            hit
            & occupied
            & cone_reaches_tile(
                c, r, spot[..., :3], cos_a, sin_a, ndc_min, ndc_max, tan_half_fov, lo, hi
            )
        )
    return (
        hit
        & cone
        & tile_box_reach(c, r, ndc_min, ndc_max, tan_half_fov, z_lo, z_hi)
        & tile_planes_reach(c, r, ndc_min, ndc_max, tan_half_fov, z_min, z_max)
    )


Z_SLACK = 1e-5  # a bin's ends widen by this fraction of z_max: float32 rounding of the bin
#                 index and of its ends can put a surface a few ulps outside its bin
