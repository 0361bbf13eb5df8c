"""Mip chains for normal maps and roughness that keep the variance of the normals they
average (RTR4 §9.13, "Blending and Filtering Materials").

Normals and roughness are not linear in the final colour: a plain mip of a bumpy normal map
is a smooth, shorter normal over a texel whose roughness never learnt about the bumps, so
highlights alias up close and turn glossier with distance. Here each texel of level k is
computed from the *moments* of the source texels in its footprint (the unit normal n, the
slopes s = (-n.x/n.z, -n.y/n.z), s.x^2, s.y^2, alpha^2 and r; alpha = r^2), and a method
turns the moments into a normal and a perceptual roughness:

* ``naive``: normalize(E[n]) and E[r], what plain mips of the two maps give (the baseline);
* ``toksvig``: normalize(E[n]), and alpha^2 widened by the shortening |E[n]| (Toksvig 2005);
* ``variance``: the normal of the mean slope, and alpha^2 + 2 sigma^2 with sigma^2 the
  slope variance (LEAN-style moments, Olano & Baker 2010). Means of moments average
  exactly, so every level is the true box filter of the source: level 2 built from level 1
  equals level 2 built from the source (the law of total variance).

The per-texel formulas live in app/reference/filtering.py. Level k is built from level k-1
by summing 2x2 blocks of moment *sums* and counting source texels (GL sizes,
h_k = max(1, h >> k)); an odd last row or column joins the last pair (a block of 3), so at
every level each source texel lies in exactly one footprint and weighs the same as every
other texel of it: each texel holds the exact box average of its footprint. (Weighting the
level k-1 texels equally instead, as plain mips do, would weigh the texels of an odd
footprint unequally.)
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from app.reference.chain import CHAIN_MIN_NORMAL_Z
from app.reference.filtering import alpha2_from_slope_variance, alpha2_toksvig
from app.reference.tonemap import srgb_decode, srgb_encode

NORMAL_FILTERS = ("naive", "toksvig", "variance")

# Smallest tangent-space n.z: decoded normals are clamped to it, and slopes are computed with
# n.z floored to it. A normal with n.z <= 0 points into the surface (invalid), and the slope
# -n.xy/n.z diverges as n.z -> 0, so one grazing texel would outweigh any footprint's second
# moment. 0.05 is 87.1 degrees from the surface normal, |slope| <= 20: one such texel adds
# up to 400/N to the slope second moment of a footprint of N texels, which saturates alpha^2
# (at sigma^2 >= 1/2) for N < 800; height-field normal maps rarely pass 80 degrees
# (|slope| 5.7), so the floor changes only outliers. One value with the chain the GL draws:
# glsl/material/chain.glsl's CHAIN_MIN_NORMAL_Z, held by its twin app/reference/chain.py.
MIN_NORMAL_Z = CHAIN_MIN_NORMAL_Z

UNIT_TOLERANCE = 1e-3  # |1 - |n|| allowed for the input normals of build_chain

# Moment channels each method needs (names of _moment's channels).
_CHANNELS = {
    "naive": ("nx", "ny", "nz", "r"),
    "toksvig": ("nx", "ny", "nz", "a2"),
    "variance": ("sx", "sy", "sxx", "syy", "a2"),
}


def decode_normal_map(rgb: np.ndarray, planes: bool = False) -> np.ndarray:
    """(H, W, 3|4) uint8 tangent-space normal map (n*0.5+0.5) -> (H, W, 3) float64 unit
    normals, z clamped > 0. ``planes``: the same values held as three planes (x, y, z),
    the array a view of them: a chain's moments read one component at a time, and a
    component held contiguous is a fraction of the memory traffic of one strided by 3.

    Each channel decodes as v/255 * 2 - 1, the exact inverse of the encoding and what a GL
    UNORM texture sampled as ``rgb * 2 - 1`` gives (so 128 decodes to 1/255, not 0: a flat
    map is flat and constant, tilted by 0.3 degrees). No channel can decode to 0, so the
    vector always has a length; it is normalised, and where n.z < MIN_NORMAL_Z (facing into
    or along the surface) n.z is raised to MIN_NORMAL_Z and x, y are rescaled to keep unit
    length. Alpha is ignored. Raises ValueError on another dtype or shape (the caller names
    the file and the scene key).
    """
    a = np.asarray(rgb)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] not in (3, 4):
        raise ValueError(f"a normal map must be (H, W, 3|4) uint8, not {a.shape} {a.dtype}")
    # A table of the 256 decoded values (the same float64 operations per value as decoding
    # each texel), then |n| as sqrt(x^2 + y^2 + z^2) summed in that order: bit for bit
    # what np.linalg.norm gives, without its temporaries.
    if planes:  # mode="clip" (a uint8 index cannot leave the table) writes into ``out``
        # directly, where "raise" fills a buffer of its own first and copies it over
        held = np.empty((3, *a.shape[:2]))
        for k in range(3):
            np.take(_DECODE_UNORM8, a[..., k], out=held[k], mode="clip")
        held /= _length(np.moveaxis(held, 0, -1))
        n = np.moveaxis(held, 0, -1)
    else:
        n = np.take(_DECODE_UNORM8, a[..., :3])  # as indexing, without its intp copy
        n /= _length(n)[..., None]
    low = n[..., 2] < MIN_NORMAL_Z
    if np.any(low):
        xy = n[low, :2]
        length = _length(xy)[..., None]  # >= sqrt(1 - 0.05^2) > 0
        n[low, :2] = xy * (np.sqrt(1.0 - MIN_NORMAL_Z**2) / length)
        n[low, 2] = MIN_NORMAL_Z
    return n


# v/255 * 2 - 1 for each 8-bit value v, computed as decode_normal_map's texels once were.
_DECODE_UNORM8 = np.arange(256, dtype=np.uint8).astype(np.float64) * (2.0 / 255.0) - 1.0


def _length(v: np.ndarray) -> np.ndarray:
    """|v| over the last axis (2 or 3 components): sqrt((x*x + y*y) + z*z), the order of
    np.linalg.norm's sum, so that it gives the same bits at a fraction of the time."""
    total = v[..., 0] * v[..., 0]
    for k in range(1, v.shape[-1]):
        total += v[..., k] * v[..., k]
    return np.sqrt(total)


@dataclass
class FilteredChain:
    """A normal map's and a roughness map's joint mip chain, level 0 first (GL sizes)."""

    normals: list[np.ndarray]  # level k: (h_k, w_k, 3) float32 unit tangent-space normals
    roughness: list[np.ndarray]  # level k: (h_k, w_k) float32 perceptual roughness r (alpha = r^2)


# A chain's source, a band of rows at a time: (y0, y1) -> (normals (y1 - y0, W, 3), perceptual
# roughness (y1 - y0, W)), float64, the texels of rows y0 .. y1 - 1 of level 0.
BandSource = Callable[[int, int], tuple[np.ndarray, np.ndarray]]

# Rows of level 0 read, summed into level 1 and written at a time: ~130k texels of a 2048-wide
# map, a few MiB of float64 temporaries that stay in the caches and in the allocator's
# free memory, where moments of the whole map were hundreds of MiB of fresh pages.
BAND_ROWS = 64


def build_chain(normals: np.ndarray, roughness: np.ndarray | float, method: str) -> FilteredChain:
    """Mip chain down to 1x1 (GL sizes: h_k = max(1, h >> k)). Level 0 is exactly the source.

    ``normals``: (H, W, 3) unit tangent-space normals; ``roughness``: (H, W) perceptual
    roughness in [0, 1] or one value for every texel; ``method`` one of NORMAL_FILTERS.
    Raises ValueError on anything else (the caller names the file and the scene key).
    """
    n, r = chain_inputs(normals, roughness, method)
    levels = chain_levels(lambda y0, y1: (n[y0:y1], r[y0:y1]), n.shape[:2], method)
    return FilteredChain([lv[..., :3] for lv in levels], [lv[..., 3] for lv in levels])


def chain_levels(
    source: BandSource,
    shape: tuple[int, int],
    method: str,
    count: int | None = None,
    rows_up_float16: bool = False,
    first: int = 0,
) -> list[np.ndarray]:
    """``build_chain``'s levels as (h_k, w_k, 4) float32 arrays (xyz normal, a roughness),
    the first ``count`` of them (None: down to 1x1), from a ``source`` read band by band
    (``BAND_ROWS``) and not checked: the caller's normals are unit and its roughness in
    [0, 1] by construction (``decode_normal_map`` and 8-bit maps, or ``build_chain``'s
    checks).

    Level 0 is the source; level 1's moment sums are made a band of level 0 at a time,
    each band an even number of rows but the last (which keeps an odd last row's block of
    three whole), so that every texel gets the same float64 operations in the same order
    as on the whole map at once: the same bits, in a fraction of the memory traffic.
    Levels 2 and up are made from level 1's sums as before.

    ``rows_up_float16``: each level as the GL takes it instead, ``float16_rows_up`` of the
    float32 level (rows bottom first; the same bits), level 0 converted a band at a time
    without a float32 copy of the whole level.

    ``first``: the levels from ``first`` on alone (a still frame samples no finer one:
    app/scene/sampled_levels.py), the same bits as the whole chain's: level 0's moments
    are still summed from the source, but level 0 is neither converted nor kept."""
    if method not in NORMAL_FILTERS:
        raise ValueError(f"unknown normal filter {method!r}; one of {', '.join(NORMAL_FILTERS)}")
    h, w = shape
    names = _CHANNELS[method]
    level0 = np.empty(
        (h, w, 4) if first == 0 else (0, 0, 4), np.float16 if rows_up_float16 else np.float32
    )
    single = max(h, w) == 1 or count == 1
    sums = None if single else np.empty((max(1, h >> 1), max(1, w >> 1), len(names)))

    def band(y0: int, y1: int) -> None:
        n, r = source(y0, y1)
        if first == 0:  # level 0 kept (``first``: its moments are summed all the same)
            rows = np.empty((y1 - y0, w, 4), np.float32) if rows_up_float16 else level0[y0:y1]
            rows[..., :3] = n  # float64 -> float32, as astype rounds
            rows[..., 3] = r
            if rows_up_float16:
                level0[h - y1 : h - y0] = rows[::-1]  # float32 -> float16, as astype rounds
        if sums is not None:
            half = sums[y0 // 2 : y0 // 2 + max(1, (y1 - y0) // 2)]
            for c, moment in enumerate(_band_moments(names, n, r)):
                half[..., c] = _halve(moment)

    each_band(band, _bands(h))
    levels = [level0]
    counts_y = np.ones(h)
    counts_x = np.ones(w)
    while sums is not None and max(counts_y.size, counts_x.size) > 1:
        if len(levels) > 1:
            sums = _halve(sums)
        counts_y, counts_x = _halve_counts(counts_y), _halve_counts(counts_x)
        level = np.empty((counts_y.size, counts_x.size, 4), np.float32)
        rows = max(1, BAND_ROWS * w // 2 // counts_x.size)  # as many texels as a band

        def filtered(y0: int, y1: int, sums=sums, cy=counts_y, cx=counts_x, level=level) -> None:
            # each moment's means a contiguous plane (the sums' channels are interleaved)
            texels = cy[y0:y1, None] * cx[None, :]
            moments = {name: sums[y0:y1, :, c] / texels for c, name in enumerate(names)}
            if method == "variance":
                _variance_texels(moments, level[y0:y1])
                return
            normal, r_level = _filtered(method, moments)
            level[y0:y1, :, :3] = normal
            level[y0:y1, :, 3] = r_level

        starts = range(0, counts_y.size, rows)  # per texel: bands change no bit
        each_band(filtered, [(y0, min(y0 + rows, counts_y.size)) for y0 in starts])
        levels.append(float16_rows_up(level) if rows_up_float16 else level)
        if count is not None and len(levels) >= count:
            break
    return levels[first:]


# Threads a chain's bands are made on: each band reads its own rows of the source and
# writes its own rows of the levels, so any order gives the same bits; numpy releases the
# GIL inside each operation, so two threads use both cores where the caller (a render
# waiting for its maps, app/textures/cache.py ``prepare``) has nothing else to run.
BAND_THREADS = 2
_BAND_POOL: ThreadPoolExecutor | None = None
_BAND_POOL_LOCK = threading.Lock()


def each_band(work: Callable[[int, int], None], bands: list[tuple[int, int]]) -> None:
    """``work(y0, y1)`` for every band, on ``BAND_THREADS`` threads (the calling one and
    the pool's), each taking the next band when it is done with one; the first exception
    raised is raised here once every band has run or been skipped."""
    if len(bands) < 2 or BAND_THREADS < 2:
        for y0, y1 in bands:
            work(y0, y1)
        return
    global _BAND_POOL
    with _BAND_POOL_LOCK:
        if _BAND_POOL is None:
            _BAND_POOL = ThreadPoolExecutor(BAND_THREADS - 1, thread_name_prefix="pbs-bands")
        pool = _BAND_POOL
    queue = iter(bands)
    lock = threading.Lock()
    failed: list[BaseException] = []

    def drain() -> None:
        while True:
            with lock:
                if failed:
                    return
                y = next(queue, None)
            if y is None:
                return
            try:
                work(*y)
            except BaseException as exc:  # raised on the caller's thread below
                with lock:
                    failed.append(exc)
                return

    helpers = [pool.submit(drain) for _ in range(BAND_THREADS - 1)]
    drain()
    for helper in helpers:
        helper.result()
    if failed:
        raise failed[0]


def _bands(height: int) -> list[tuple[int, int]]:
    """Row ranges (y0, y1) covering 0 .. height: ``BAND_ROWS`` each (an even number), the
    last taking what remains, and a lone odd last row joining the band before it (its
    footprint at level 1 is a block of three rows)."""
    starts = list(range(0, height, BAND_ROWS))
    ends = [*starts[1:], height]
    if len(starts) > 1 and ends[-1] - starts[-1] == 1:
        starts.pop()
        ends.pop(-2)
    return list(zip(starts, ends, strict=True))


def _band_moments(names: tuple[str, ...], n: np.ndarray, r: np.ndarray) -> list[np.ndarray]:
    """``_moment`` of each name over one band, a slope computed once for its square."""
    out: dict[str, np.ndarray] = {}
    nz = None
    for name in names:
        if name in ("sx", "sy"):
            if nz is None:
                nz = np.maximum(n[..., 2], MIN_NORMAL_Z)
            s = np.divide(n[..., "xy".index(name[1])], nz)
            np.negative(s, out=s)  # -(x / z): -x / z's bits, without a negated copy of x
            out[name], out[name[0] + name[1] * 2] = s, s * s
        elif name not in out:
            out[name] = _moment(name, n, r)
    return [out[name] for name in names]


def box_mips(values: np.ndarray) -> list[np.ndarray]:
    """Mips of linear data (H, W) or (H, W, C) down to 1x1 (GL sizes), level 0 untouched:
    each texel the exact mean of the source texels under its footprint (the moments'
    averaging above, for data that is averaged as it is: masks, metallic, colour)."""
    a = np.asarray(values, np.float64)
    if a.ndim == 3:
        return box_levels(lambda y0, y1: a[y0:y1], a.shape)
    levels = box_levels(lambda y0, y1: a[y0:y1, :, None], (*a.shape, 1))
    return [level[..., 0] for level in levels]


def box_levels(
    source: Callable[[int, int], np.ndarray],
    shape: tuple[int, int, int],
    rows_up_float16: bool = False,
    float16_rows: Callable[[int, int], np.ndarray] | None = None,
    first: int = 0,
) -> list[np.ndarray]:
    """``box_mips``'s levels, (h_k, w_k, C) float32, of the (H, W, C) float64 data that
    ``source(y0, y1)`` gives a band of rows at a time (as ``chain_levels`` reads its
    source, with the same bits as the whole map at once); ``rows_up_float16`` as there.
    ``float16_rows(y0, y1)``, where given with ``rows_up_float16``: the band's level-0
    rows as float16 (rows top first), the same bits as the cast of ``source``'s, made
    cheaper by the caller (``unorm8_float16``: numpy's float16 cast is a scalar loop).
    ``first``: the levels from ``first`` on alone, as ``chain_levels``'s."""
    h, w, c = shape
    level0 = np.empty(
        (h, w, c) if first == 0 else (0, 0, c), np.float16 if rows_up_float16 else np.float32
    )
    sums = None if max(h, w) == 1 else np.empty((max(1, h >> 1), max(1, w >> 1), c))

    def band(y0: int, y1: int) -> None:
        values = source(y0, y1)
        if first > 0:  # level 0 not kept; its values are summed all the same
            pass
        elif rows_up_float16 and float16_rows is not None:
            level0[h - y1 : h - y0] = float16_rows(y0, y1)[::-1]
        elif rows_up_float16:  # float64 -> float32 -> float16, each as astype rounds
            level0[h - y1 : h - y0] = values.astype(np.float32)[::-1]
        else:
            level0[y0:y1] = values  # float64 -> float32, as astype rounds
        if sums is not None:
            sums[y0 // 2 : y0 // 2 + max(1, (y1 - y0) // 2)] = _halve(values)

    each_band(band, _bands(h))
    levels = [level0]
    counts_y, counts_x = np.ones(h), np.ones(w)
    while sums is not None and max(counts_y.size, counts_x.size) > 1:
        if len(levels) > 1:
            sums = _halve(sums)
        counts_y, counts_x = _halve_counts(counts_y), _halve_counts(counts_x)
        means = sums / (counts_y[:, None, None] * counts_x[None, :, None])
        level = means.astype(np.float32)
        levels.append(float16_rows_up(level) if rows_up_float16 else level)
    return levels[first:]


def unorm8_box_levels(
    texels: np.ndarray, rows_up_float16: bool = False, first: int = 0
) -> list[np.ndarray]:
    """``box_levels`` of an 8-bit channel, (H, W) uint8 (a view of an image's storage
    will do) read as v / 255: levels (h_k, w_k, 1) float32, or float16 rows bottom first
    with ``rows_up_float16``; ``first`` as there (a glTF metallic or occlusion map).

    Made from the integers: a footprint's texels are summed exactly (16 bits at level 1,
    where a footprint holds at most nine, 64 below) and each mean is one division
    S / (255 n) rounded to float32, which ``box_levels`` reaches through float64 sums of
    the rounded quotients v / 255 (the same bits on the maps tests/test_mips.py tries,
    including every sum level 1 can hold). Level 1's S and 255 n are exact in float32,
    whose division rounds the mean once, as the float64 one followed by the float32 cast
    does (no float64 quotient of so small a denominator falls on a float32 tie). Level 1
    is made a band of rows at a time (``each_band``), so that nothing of its size is held
    but its 16-bit sums and the level itself, where box_levels held float64 sums, means
    and a float32 copy: fresh memory's page faults were much of their time
    (docs/performance.md, "A real asset against f3d"). The levels below are a quarter of
    its size and divide in float64."""
    h, w = texels.shape
    out_type = np.float16 if rows_up_float16 else np.float32
    levels: list[np.ndarray] = []
    if first == 0:
        level0 = unorm8_float16(texels[::-1]) if rows_up_float16 else texels / np.float32(255)
        levels.append(np.ascontiguousarray(level0)[..., None])
    if max(h, w) == 1:
        return levels
    counts_y, counts_x = _halve_counts(np.ones(h)), _halve_counts(np.ones(w))
    sums = np.empty((counts_y.size, counts_x.size), np.uint16)
    level = np.empty((*sums.shape, 1), out_type) if first <= 1 else None

    def band(y0: int, y1: int) -> None:  # level-0 rows y0 .. y1 (``_bands``)
        rows = slice(y0 // 2, y0 // 2 + max(1, (y1 - y0) // 2))
        block = sums[rows] = _halve(texels[y0:y1], np.uint16)
        if level is not None:  # rows bottom first where float16: the level's rows backwards
            mean = _unorm8_means(block, counts_y[rows], counts_x, np.float32)[..., None]
            at = slice(len(sums) - rows.stop, len(sums) - rows.start) if rows_up_float16 else rows
            level[at] = mean[::-1] if rows_up_float16 else mean

    each_band(band, _bands(h))
    if level is not None:
        levels.append(level)
    k = 1
    while max(sums.shape) > 1:
        k += 1
        sums = _halve(sums, np.uint64)
        counts_y, counts_x = _halve_counts(counts_y), _halve_counts(counts_x)
        if k >= first:
            mean = _unorm8_means(sums, counts_y, counts_x, np.float64).astype(np.float32)
            levels.append(float16_rows_up(mean[..., None]) if rows_up_float16 else mean[..., None])
    return levels


def _unorm8_means(
    sums: np.ndarray, counts_y: np.ndarray, counts_x: np.ndarray, dtype: type
) -> np.ndarray:
    """Footprint sums of 8-bit texels over 255 times their texel counts (``counts_y`` per
    row, ``counts_x`` per column), divided in ``dtype``: one number where every footprint
    holds as many texels (even sides), else each footprint's."""
    if np.ptp(counts_y) == 0 and np.ptp(counts_x) == 0:
        counts = dtype(255.0 * counts_y[0] * counts_x[0])
    else:
        counts = (255.0 * np.outer(counts_y, counts_x)).astype(dtype)
    return np.divide(sums, counts, dtype=dtype)


# v / 255 for each 8-bit value v, cast float64 -> float32 -> float16 as astype rounds: an
# 8-bit channel's level-0 texels through ``np.take`` of this are the same bits as the
# casts of its float64 values.
UNORM8_FLOAT16 = (np.arange(256, dtype=np.uint8) / 255.0).astype(np.float32).astype(np.float16)


def unorm8_float16(texels: np.ndarray) -> np.ndarray:
    """uint8 texels as float16 ``v / 255`` (``UNORM8_FLOAT16``)."""
    return np.take(UNORM8_FLOAT16, texels)


def float16_rows_up(level: np.ndarray) -> np.ndarray:
    """``np.ascontiguousarray(level[::-1], np.float16)`` (the same bits: each texel's own
    cast), converted a band of rows at a time on two threads (``each_band``): numpy's
    float16 cast is a scalar loop, 0.1 s for a 2048^2 RGBA level."""
    out = np.empty(level.shape, np.float16)
    flipped = level[::-1]
    rows = max(1, (1 << 18) // max(1, level[0].size))  # ~256k values a band

    def band(y0: int, y1: int) -> None:
        np.copyto(out[y0:y1], flipped[y0:y1], casting="same_kind")

    each_band(band, [(y, min(y + rows, len(level))) for y in range(0, len(level), rows)])
    return out


def chain_inputs(
    normals: np.ndarray, roughness: np.ndarray | float, method: str
) -> tuple[np.ndarray, np.ndarray]:
    """``build_chain``'s arguments checked: (normals, roughness per texel), float64; a
    ValueError naming what is wrong."""
    if method not in NORMAL_FILTERS:
        raise ValueError(f"unknown normal filter {method!r}; one of {', '.join(NORMAL_FILTERS)}")
    n = np.asarray(normals, np.float64)
    if n.ndim != 3 or n.shape[2] != 3 or n.shape[0] < 1 or n.shape[1] < 1:
        raise ValueError(f"normals must be (H, W, 3), not {n.shape}")
    if not np.all(np.isfinite(n)):
        raise ValueError("normals must be finite")
    if np.max(np.abs(_length(n) - 1.0)) > UNIT_TOLERANCE:
        raise ValueError("normals must have unit length")
    r = np.asarray(roughness, np.float64)
    if r.ndim == 0:
        r = np.full(n.shape[:2], float(r))
    if r.shape != n.shape[:2]:
        raise ValueError(f"roughness must be {n.shape[:2]} like the normals, not {r.shape}")
    if not np.all(np.isfinite(r)) or r.min() < 0.0 or r.max() > 1.0:
        raise ValueError("roughness must lie in [0, 1]")
    return n, r


def _moment(name: str, n: np.ndarray, r: np.ndarray) -> np.ndarray:
    """One per-texel moment (H, W): normal components, slopes (n.z floored to
    MIN_NORMAL_Z), squared slopes, alpha^2 = r^4, or r."""
    if name in ("nx", "ny", "nz"):
        return n[..., "xyz".index(name[1])]
    if name == "a2":
        return r**4
    if name == "r":
        return r
    s = -n[..., "xy".index(name[1])] / np.maximum(n[..., 2], MIN_NORMAL_Z)
    return s * s if len(name) == 3 else s


def _halve(a: np.ndarray, dtype: type | None = None) -> np.ndarray:
    """Sums over the next level's footprints: 2x2 blocks of rows and columns, an odd last
    row or column joining the last pair, a side of 1 staying 1; ``dtype``: what the sums
    are added in (an 8-bit map's widened), else ``a``'s.

    Pairs are added as two strided views (a[0::2] + a[1::2]) and a block of three as
    a + (b + c): the same additions in the same order as np.add.reduceat over the blocks,
    so the same bits, without reduceat's per-block loop."""
    add = functools.partial(np.add, dtype=dtype or a.dtype)
    for axis in (0, 1):
        size = a.shape[axis]
        if size == 1:
            continue
        pairs = size // 2
        first = [slice(None)] * a.ndim
        second = [slice(None)] * a.ndim
        first[axis] = slice(0, 2 * pairs, 2)
        second[axis] = slice(1, 2 * pairs, 2)
        halved = add(a[tuple(first)], a[tuple(second)])
        if size % 2:  # the last block: a + (b + c), the order reduceat adds three in
            block = [[slice(None)] * a.ndim for _ in range(3)]
            for k in range(3):
                block[k][axis] = slice(size - 3 + k, size - 2 + k)
            end = [slice(None)] * a.ndim
            end[axis] = slice(pairs - 1, pairs)
            a_, b_, c_ = (a[tuple(b)] for b in block)
            halved[tuple(end)] = add(a_, add(b_, c_))
        a = halved
        add = np.add
    return a


def _halve_counts(counts: np.ndarray) -> np.ndarray:
    """Source texels per footprint along one axis at the next level."""
    return np.add.reduceat(counts, np.arange(0, 2 * max(1, counts.size // 2), 2))


def _unit(v: np.ndarray) -> np.ndarray:
    """v / |v| over the last axis, +Z where v vanishes (only normals that cancel exactly)."""
    length = _length(v)[..., None]
    up = np.zeros_like(v)
    up[..., 2] = 1.0
    return np.where(length > 1e-300, v / np.where(length > 1e-300, length, 1.0), up)


def _variance_texels(m: dict[str, np.ndarray], out: np.ndarray) -> None:
    """``_filtered("variance", m)`` written into ``out`` (..., 4), the same bits, a plane
    at a time: the normal (-E[s.x], -E[s.y], 1) has a length of at least 1, so ``_unit``'s
    guard against a vanishing one never applies, and its length's squares are the
    variances' E[s]^2 ((-a)^2 is a^2, 1^2 is 1)."""
    sx, sy = m["sx"], m["sy"]
    sx2, sy2 = sx * sx, sy * sy
    var_x, var_y = m["sxx"] - sx2, m["syy"] - sy2
    sigma2 = np.maximum(0.5 * (var_x + var_y), 0.0)
    alpha2 = alpha2_from_slope_variance(m["a2"], sigma2)
    length = sx2  # sqrt((x*x + y*y) + z*z) as _length sums it, in place
    length += sy2
    length += 1.0
    np.sqrt(length, out=length)
    for k, slope in enumerate((sx, sy)):
        component = np.divide(slope, length)
        np.negative(component, out=component)  # -(a / l): (-a) / l's bits
        out[..., k] = component
    out[..., 2] = np.divide(1.0, length)
    out[..., 3] = alpha2**0.25


def _filtered(method: str, m: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(normal, perceptual roughness) of each texel from the mean moments ``m`` of its
    footprint."""
    if method == "naive":
        return _unit(np.stack([m["nx"], m["ny"], m["nz"]], axis=-1)), m["r"]
    if method == "toksvig":
        mean_n = np.stack([m["nx"], m["ny"], m["nz"]], axis=-1)
        alpha2 = alpha2_toksvig(m["a2"], _length(mean_n))
        return _unit(mean_n), alpha2**0.25
    # Isotropic: the G-buffer carries one roughness, so sigma^2 is the mean of the two
    # per-axis slope variances (clamped at 0 against rounding in E[s^2] - E[s]^2).
    var_x = m["sxx"] - m["sx"] * m["sx"]
    var_y = m["syy"] - m["sy"] * m["sy"]
    sigma2 = np.maximum(0.5 * (var_x + var_y), 0.0)
    alpha2 = alpha2_from_slope_variance(m["a2"], sigma2)
    normal = _unit(np.stack([-m["sx"], -m["sy"], np.ones_like(m["sx"])], axis=-1))
    return normal, alpha2**0.25


@functools.cache
def srgb_tables() -> tuple[np.ndarray, np.ndarray]:
    """sRGB-encoded 8-bit value -> linear value in units of 1/65535 (IEC 61966-2-1's
    decode), and the sum of four such values -> the 8-bit encoding of their mean (its
    encode, rounded): a 2x2 box in linear space in integer arithmetic, as the GL filters
    sRGB texels (decoded before they are averaged). Made at first use, not by every
    process that imports this module.

    The second table, ``round(255 encode(s / SUM4))`` for every sum s, steps up once for
    each of the 255 codes above 0: it is made from the sum each step starts at, that
    formula evaluated on a few sums around the decode of the code's lower midpoint
    (``_code_starts``), instead of on all 262,141 (tens of milliseconds of powers in the
    cold render that first asks for it). tests/test_mips.py holds it to the formula at
    every sum."""
    linear16 = np.round(srgb_decode(np.arange(256) / 255.0) * 65535.0).astype(np.uint32)
    starts = _code_starts()
    lengths = np.diff(np.concatenate([[0], starts, [SUM4 + 1]]))
    of_sum4 = np.repeat(np.arange(256, dtype=np.uint8), lengths)
    return linear16, of_sum4


SUM4 = 4 * 65535  # the largest sum of four ``srgb_tables`` linear values


def _code_starts() -> np.ndarray:
    """For each 8-bit code k = 1..255, the least sum s of four linear values whose mean
    encodes to k or more, ``round(255 encode(s / SUM4)) >= k``: the encode is monotonic,
    so s lies within a step of where the decode of (k - 1/2) / 255 puts it (the two
    formulas agree to far less than a sum's step, 1 / SUM4), and a window of sums there
    holds the step (checked: a window that missed it raises)."""
    codes = np.arange(1, 256)
    guess = np.floor(srgb_decode((codes - 0.5) / 255.0) * SUM4).astype(np.int64)
    window = np.clip(guess[:, None] + np.arange(-4, 5), 0, SUM4)  # (255, 9)
    encoded = np.round(srgb_encode(window / float(SUM4)) * 255.0)
    above = encoded >= codes[:, None]
    if above[:, 0].any() or not above[:, -1].all():
        raise AssertionError("an sRGB code's step lies outside its window")
    return window[np.arange(len(codes)), np.argmax(above, axis=1)]


@functools.cache
def srgb_pair_tables() -> tuple[np.ndarray, np.ndarray]:
    """``srgb_tables``' decode for two 8-bit channels at once: indexed by the 16-bit word
    of two adjacent bytes of an RGBA texel (R and G, B and A, as memory holds them), the
    64-bit word of their two 32-bit linear values in the same order, so that one lookup
    decodes two channels and one 64-bit add sums two (a 2x2 box's sum of four, at most
    4 x 65535, never carries from one half into the other). The B-and-A table keeps
    alpha as it is (alpha is linear). Byte order is the machine's for both views, so the
    halves fall where the bytes were."""
    linear16, _ = srgb_tables()
    pairs = np.arange(1 << 16, dtype=np.uint16).view(np.uint8).reshape(-1, 2)  # memory bytes
    rg = linear16[pairs].astype(np.uint32)
    ba = np.stack([linear16[pairs[:, 0]], pairs[:, 1]], axis=1).astype(np.uint32)
    return rg.view(np.uint64)[:, 0].copy(), ba.view(np.uint64)[:, 0].copy()


SRGB_BAND_TEXELS = 1 << 16  # source texels a band of srgb_box_levels reads


def _uniform_texel(block: np.ndarray) -> np.ndarray | None:
    """The one RGBA texel every texel of the (rows, w, 4) uint8 ``block`` holds, or None.
    Texels are compared as 32-bit words (a comparison whose innermost axis is a texel's 4
    bytes runs numpy's loop once a texel), the first row first, so a varied band costs a
    row's comparison; None too where a texel's bytes are not contiguous (no such view)."""
    try:
        words = block.view(np.uint32)[..., 0]  # a view of the same bytes, no copy
    except ValueError:
        return None
    first = words[0, 0]
    if not (words[0] == first).all() or not (words == first).all():
        return None
    return block[0, 0].copy()


def srgb_box_levels(level0: np.ndarray) -> list[np.ndarray]:
    """The mips of an (h, w, 4) uint8 sRGB colour map with linear alpha, h and w equal
    powers of two, each texel the 2x2 box of the level above in linear space (alpha
    averaged as it is), rounded to 8 bits: the GL's sRGB mips within a step or two per
    level (llvmpipe encodes with an approximation of its own), made on the CPU where the
    GL's would cost a blit (its machine code compiled once a process: a tenth of a
    second on llvmpipe) on the render's main thread. Level 0 is ``level0`` itself.

    Each level is made a band of ``SRGB_BAND_TEXELS`` source texels at a time, on two
    threads (``each_band``): the table lookups' index and value arrays of a whole level
    were some 50 MB of fresh memory for a 1024² map, a band's are reused."""
    h, w = level0.shape[:2]
    assert h == w and h & (h - 1) == 0, "a square power-of-two map"
    _, of_sum4 = srgb_tables()
    rg_table, ba_table = srgb_pair_tables()

    def boxed(block: np.ndarray, out: np.ndarray) -> None:
        # Two channels a lookup (srgb_pair_tables: half the lookups and index casts of
        # one a channel); rows summed first, then column pairs, both halves at once
        words = block.view(np.uint16)  # (rows, w, 2): R and G, B and A
        sums = []
        for table, half in ((rg_table, 0), (ba_table, 1)):
            linear = np.take(table, words[..., half])
            linear = linear[0::2] + linear[1::2]
            total = linear[:, 0::2] + linear[:, 1::2]
            sums.append(total.view(np.uint32).reshape(*total.shape, 2))
        out[..., 0] = np.take(of_sum4, sums[0][..., 0])
        out[..., 1] = np.take(of_sum4, sums[0][..., 1])
        out[..., 2] = np.take(of_sum4, sums[1][..., 0])
        out[..., 3] = (sums[1][..., 1] + 2) >> 2

    levels = [level0]
    while levels[-1].shape[0] > 1:
        above = levels[-1]
        half = above.shape[0] // 2
        level = np.empty((half, above.shape[1] // 2, 4), np.uint8)
        rows = max(1, SRGB_BAND_TEXELS // (2 * above.shape[1]))  # output rows a band

        def band(y0: int, y1: int, above: np.ndarray = above, level: np.ndarray = level) -> None:
            block, out = above[2 * y0 : 2 * y1], level[y0:y1]
            texel = _uniform_texel(block)
            if texel is None:
                boxed(block, out)
            else:  # one texel value throughout (a mostly black emission map): its box once
                boxed(np.broadcast_to(texel, (2, 2, 4)), out[:1, :1])
                out[...] = out[0, 0]

        each_band(band, [(y, min(y + rows, half)) for y in range(0, half, rows)])
        levels.append(level)
    return levels
