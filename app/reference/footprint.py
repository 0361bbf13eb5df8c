"""Twin of glsl/common/footprint.glsl and glsl/passes/srgb_mips.frag: a mip level's footprints
(``footprint_last_child``, ``footprint_texels``: the GLSL functions of the same names), its
texels as the exact means of their footprints (app/textures/mips.py's footprints, GL sizes),
and a colour map's sRGB mips made of those means in linear light.

Along an axis of n texels, texel i of level k (n_k = max(1, n >> k) texels) covers level-0
texels i 2^k .. (i + 1) 2^k - 1, the last one every texel to n (an odd remainder at each
halving joins the last pair). The GL builds level k from level k - 1, each child weighted
by the level-0 texels it covers, which is the same mean; here every level is taken from
level 0 in float64. Imports nothing above the reference layer.
"""

from __future__ import annotations

import numpy as np

from app.reference.tonemap import srgb_decode, srgb_encode


def footprint_starts(n: int, k: int) -> np.ndarray:
    """The first level-0 texel of each texel of level k along an axis of n texels."""
    return np.arange(max(1, n >> k)) << k


def footprint_last_child(
    i: np.ndarray | int, n: np.ndarray | int, size: np.ndarray | int
) -> np.ndarray:
    """The last texel of level k - 1 (a side of ``n``) under texel ``i`` of level k (a side
    of ``size``), along an axis; the first is min(2 i, n - 1). Texel i covers 2 i and
    2 i + 1, the last texel of an odd side also 2 i + 2; a side of 1 has one child, 0."""
    i, n, size = (np.asarray(x, np.int64) for x in (i, n, size))
    odd_end = (i == size - 1) & (n % 2 == 1)
    return np.where(n == 1, 0, 2 * i + 1 + odd_end)


def footprint_texels(
    i: np.ndarray | int, k: np.ndarray | int, size: np.ndarray | int, n0: np.ndarray | int
) -> np.ndarray:
    """Level-0 texels under texel ``i`` of level ``k`` (a side of ``size``) along an axis of
    level-0 side ``n0``, as float64 (the GLSL's float, a weight): i 2^k .. (i + 1) 2^k - 1,
    the last texel of the level to n0 (every odd remainder on the way joins it)."""
    i, k, size, n0 = (np.asarray(x, np.int64) for x in (i, k, size, n0))
    end = np.where(i == size - 1, n0, (i + 1) << k)
    return (end - (i << k)).astype(np.float64)


def footprint_means(values: np.ndarray) -> list[np.ndarray]:
    """Levels 0 .. 1x1 of (h, w, c) values (float64): each texel of level k the mean of
    the level-0 values in its footprint. Level 0 is ``values`` as float64."""
    a = np.asarray(values, np.float64)
    h, w = a.shape[:2]
    levels = [a]
    for k in range(1, max(h, w).bit_length()):
        ys, xs = footprint_starts(h, k), footprint_starts(w, k)
        sums = np.add.reduceat(np.add.reduceat(a, ys, axis=0), xs, axis=1)
        counts_y = np.diff(np.append(ys, h))
        counts_x = np.diff(np.append(xs, w))
        levels.append(sums / (counts_y[:, None, None] * counts_x[None, :, None]))
    return levels


def srgb_footprint_levels(texels: np.ndarray) -> list[np.ndarray]:
    """The mips of an (h, w, 4) uint8 colour map (sRGB colour, linear alpha): each texel
    the footprint mean of the decoded colour, encoded, and of alpha, as float64 8-bit
    values (0 .. 255, unrounded). Level 0 is the map's own values."""
    t = np.asarray(texels)
    linear = np.concatenate([srgb_decode(t[..., :3] / 255.0), t[..., 3:] / 255.0], axis=-1)
    out = []
    for level in footprint_means(linear):
        encoded = np.concatenate([srgb_encode(level[..., :3]), level[..., 3:]], axis=-1)
        out.append(encoded * 255.0)
    return out
