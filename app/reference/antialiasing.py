"""Float64 twins of the antialiasing passes (docs/antialiasing.md, "Twins"): gbaa's resolve
(glsl/passes/gbaa.frag), FXAA (glsl/passes/fxaa.frag), the jittered accumulation
(glsl/passes/accumulate.frag with ``jitter_offsets``' Halton (2, 3) points) and the
subpixel reconstruction's resolve (glsl/passes/sraa.frag).

Each function takes what its shader reads, as read back from the real targets: arrays
indexed ``[y, x]`` in GL's order (row 0 at the bottom, +y up), the G-buffer's RT2 (view
depth, material id) as ``surface`` (H, W, 2), its edge target RT7 as ``edge`` (H, W, 4:
distances in pixels to the surface's edge along +x, -x, +y, -y), linear HDR RGBA as
``hdr`` (H, W, 4), the display image as RGBA8 bytes (H, W, 4). A texel fetch past the
image is clamped to its border, as ``texelFetch(..., clamp(px, 0, last))`` is.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from app.reference.tonemap import post_process, srgb_decode, srgb_encode

# glsl/passes/gbaa.frag's defines
GBAA_AXIS_TIE = 1.1  # a neighbour's edge counts along an axis within 10 % of its nearest
GBAA_DEPTH_TOLERANCE = 0.1  # view depths further apart than this fraction differ
GBAA_ALONG_EDGE_CLAMP = 1.5  # an edge pixel's own part stays within this factor of the centre's
GBAA_SLIVER_REACH = 1.5  # a neighbour's edge this far from its centre can reach into a pixel
GBAA_SLIVER_CAP = 0.5  # the most a half-plane that misses a pixel's centre covers of it
# the interior correction leaves out a neighbour past this many times the display's white:
# a saturated pixel's radiance says nothing of its highlight's size, and its 1/24 share
# drew a plus around every highlight smaller than a pixel
GBAA_SPILL = 1.0
# the four neighbours, +x, -x, +y, -y (gbaa.frag's STEPS; k ^ 1 is the opposite one)
STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))

# glsl/passes/fxaa.frag's defines and constants
FXAA_EDGE_THRESHOLD = 0.125
FXAA_EDGE_THRESHOLD_MIN = 0.0312
FXAA_SUBPIX = 0.75
FXAA_STEPS = 12
FXAA_LUMA = (0.299, 0.587, 0.114)  # Rec. 601 luma weights of the encoded values


def shifted(a: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """``a[y + dy, x + dx]`` at every pixel, the index clamped to the image (a clamped
    ``texelFetch``)."""
    h, w = a.shape[:2]
    ys = np.clip(np.arange(h) + dy, 0, h - 1)
    xs = np.clip(np.arange(w) + dx, 0, w - 1)
    return a[ys][:, xs]


# ---------------------------------------------------------------------------------------
# gbaa (glsl/passes/gbaa.frag)


def gbaa_other_surface(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether RT2 texels ``a`` and ``b`` (..., 2) hold different surfaces: one of them the
    background, or both surfaces of another material id or view depths more than
    ``GBAA_DEPTH_TOLERANCE`` of the nearer apart (gbaa.frag's ``other``)."""
    da, db = a[..., 0], b[..., 0]
    far_apart = np.abs(da - db) > GBAA_DEPTH_TOLERANCE * np.minimum(da, db)
    return ((db > 0) != (da > 0)) | ((da > 0) & ((a[..., 1] != b[..., 1]) | far_apart))


def gbaa_same_surface(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether ``a`` and ``b`` hold the same surface, neither the background."""
    return (a[..., 0] > 0) & (b[..., 0] > 0) & ~gbaa_other_surface(a, b)


def gbaa_in_front(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether surface ``a`` lies in front of ``b`` and is another one: a surface before
    the background, or another surface, the nearer."""
    da, db = a[..., 0], b[..., 0]
    return (da > 0) & ((db <= 0) | (gbaa_other_surface(a, b) & (da < db)))


def gbaa_marked(surface: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels the mark draw (GBAA_MARK) writes depth 0 at, those with
    another surface in a 4-neighbour; the resolve runs there alone."""
    surface = np.asarray(surface, np.float64)
    marked = np.zeros(surface.shape[:2], bool)
    for dx, dy in STEPS:
        marked |= gbaa_other_surface(surface, shifted(surface, dx, dy))
    return marked


def gbaa_box_coverage(d: np.ndarray, e: np.ndarray, offset: float) -> np.ndarray:
    """The area of a unit pixel on its surface's side of a straight edge that crosses the
    axes through a pixel's centre at ``d`` (toward the edge) and ``e`` (across), the pixel
    measured ``offset`` pixels from that centre toward the edge: the box filter of a
    half-plane, exact at the pixel's corners. With the normal (1/d, 1/e) (u the larger
    component, v the smaller) the measured centre lies s = 1 - offset/d inside the line;
    the area is 0.5 + s/u while the line leaves through two opposite sides (|s| <= (u -
    v)/2), a corner's triangle t^2 / 2uv (t = (u + v)/2 - |s|) or 1 less it beyond, and 0
    or 1 past the corners."""
    a = 1.0 / np.maximum(np.asarray(d, np.float64), 1e-4)  # through the centre: 1/2
    b = 1.0 / np.maximum(np.asarray(e, np.float64), 1e-4)
    u, v = np.maximum(a, b), np.minimum(a, b)
    s = 1.0 - offset * a
    t = 0.5 * (u + v) - np.abs(s)
    band = 0.5 + s / u
    corner = t * t / (2.0 * u * v)
    inner = np.where(np.abs(s) <= 0.5 * (u - v), band, np.where(s > 0, 1.0 - corner, corner))
    return np.where(t <= 0, np.where(s > 0, 1.0, 0.0), inner)


@cache
def gbaa_saturation(tonemap: str) -> float:
    """The exposed radiance past which ``tonemap``'s display is white: the least grey
    value whose display value rounds to the top 8-bit step (bisection on ``post_process``,
    to 1e-6 relative); infinite where no value up to 1e12 reaches it."""
    lo, hi = 0.0, 1.0
    top = (255 - 0.5) / 255.0
    while post_process(np.full(3, hi), 0.0, tonemap)[0] < top:
        lo, hi = hi, 2.0 * hi
        if hi > 1e12:
            return float("inf")
    while hi - lo > 1e-6 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if post_process(np.full(3, mid), 0.0, tonemap)[0] >= top else (mid, hi)
    return hi


def gbaa_interior_radiance(c: np.ndarray, n: list[np.ndarray], spill: float = np.inf) -> np.ndarray:
    """A pixel's area mean from its centre's radiance ``c`` (..., 4) and its 4
    neighbours' ``n`` (the same surface), to second order: ``c + (sum n - 4c) / 24`` (the
    midpoint rule misses (f_xx + f_yy) / 24 of the box filter's integral; the 5-point
    Laplacian; positive weights, unclamped), alpha ``c``'s. A neighbour whose brightest
    channel is past ``spill`` (radiance: ``GBAA_SPILL`` times ``gbaa_saturation`` over
    the exposure) counts as ``c``: its 1/24 alone would turn the pixel white (a highlight
    smaller than a pixel drew a white plus around it, where the area truth is not)."""
    c = np.asarray(c, np.float64)
    total = np.zeros_like(c)
    for k in range(4):
        past = np.asarray(n[k], np.float64)[..., :3].max(axis=-1, keepdims=True) > spill
        total = total + np.where(past, c, n[k])
    mean = c + (total - 4.0 * c) / 24.0
    return np.concatenate([mean[..., :3], c[..., 3:]], axis=-1)


def gbaa_along_edge(
    c: np.ndarray, surface: np.ndarray, around: list[np.ndarray], n: list[np.ndarray]
) -> np.ndarray:
    """(..., 4) the interior correction of a marked pixel's own part: the second
    differences of the axes whose two neighbours both hold its surface, each over 24, the
    colour held within ``GBAA_ALONG_EDGE_CLAMP`` of ``c``; alpha unchanged."""
    delta = np.zeros_like(c)
    for axis in range(2):
        k = 2 * axis
        both = gbaa_same_surface(surface, around[k]) & gbaa_same_surface(surface, around[k + 1])
        delta = delta + np.where(both[..., None], (n[k] + n[k + 1] - 2.0 * c) / 24.0, 0.0)
    rgb = np.clip(
        c[..., :3] + delta[..., :3],
        c[..., :3] / GBAA_ALONG_EDGE_CLAMP,
        c[..., :3] * GBAA_ALONG_EDGE_CLAMP,
    )
    return np.concatenate([rgb - c[..., :3], np.zeros_like(c[..., 3:])], axis=-1)


def gbaa_coverage(
    surface: np.ndarray, edge: np.ndarray, exact: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The resolve's weights: (H, W, 4) the area of each pixel covered by its neighbour
    +x, -x, +y, -y, and (H, W) int ``toward``, the neighbour behind the pixel across its
    own nearest edge (-1: none). The pixel's own edge toward a neighbour behind it (the
    smallest distance under 0.5, the first of a tie) gives that neighbour 0.5 - d of the
    pixel (a half-plane edge at distance d along the axis nearest its normal covers the
    centre's side by 0.5 + d). A neighbour in front whose edge toward this pixel lies
    0.5 < d < 1 from its centre, along an axis within ``GBAA_AXIS_TIE`` of its nearest
    across, covers d - 0.5 of it; where neighbours across x and across y both do (a
    silhouette near 45 degrees), only the axis whose two cover more is kept.
    ``exact`` (a still's resolve, GBAA_EXACT): both areas are
    ``gbaa_box_coverage``'s, from the distance along the axis and the nearer across it,
    exact at the pixel's corners: the own edge counts under 1 pixel away (1 - its area),
    and a neighbour's edge 0 < d < ``GBAA_SLIVER_REACH`` from its centre along any axis,
    its area at most ``GBAA_SLIVER_CAP`` (a half-plane that misses the centre of a square
    covers at most half of it: a slanted edge just past the pixel's centre from a
    neighbour's, d a little over 1, still covers about half the pixel)."""
    surface = np.asarray(surface, np.float64)
    own = np.asarray(edge, np.float64)
    shape = surface.shape[:2]
    around = [shifted(surface, dx, dy) for dx, dy in STEPS]
    edges = [shifted(own, dx, dy) for dx, dy in STEPS]
    weight = np.zeros((*shape, 4))
    nearest = np.full(shape, 1.0 if exact else 0.5)
    toward = np.full(shape, -1, np.int64)
    for k in range(4):
        take = gbaa_in_front(surface, around[k]) & (own[..., k] < nearest)
        nearest = np.where(take, own[..., k], nearest)
        toward = np.where(take, k, toward)
    own_across = [np.minimum(own[..., 2], own[..., 3])] * 2 + [
        np.minimum(own[..., 0], own[..., 1])
    ] * 2
    for k in range(4):
        part = 1.0 - gbaa_box_coverage(nearest, own_across[k], 0.0) if exact else 0.5 - nearest
        weight[..., k] = np.where(toward == k, part, 0.0)
    front = np.zeros((*shape, 4))
    for k in range(4):
        theirs = edges[k]
        d = theirs[..., k ^ 1]  # from the neighbour toward this pixel
        across = (
            np.minimum(theirs[..., 2], theirs[..., 3])
            if k < 2
            else np.minimum(theirs[..., 0], theirs[..., 1])
        )
        if exact:
            reaches = (d > 0.0) & (d < GBAA_SLIVER_REACH)
            part = np.minimum(gbaa_box_coverage(d, across, 1.0), GBAA_SLIVER_CAP)
        else:
            reaches, part = (d > 0.5) & (d < 1.0) & (d <= GBAA_AXIS_TIE * across), d - 0.5
        front[..., k] = np.where(gbaa_in_front(around[k], surface) & reaches, part, 0.0)
    fx = front[..., 0] + front[..., 1]
    fy = front[..., 2] + front[..., 3]
    tie = (fx > 0) & (fy > 0)
    front[..., 2:] = np.where((tie & (fx >= fy))[..., None], 0.0, front[..., 2:])
    front[..., :2] = np.where((tie & (fx < fy))[..., None], 0.0, front[..., :2])
    return weight + front, toward


def gbaa_centroid_radiance(c: np.ndarray, b: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Radiance ``c`` (..., 4) of a surface pixel moved ``shift`` pixels (...) from its
    centre to the centroid of its covered part, linear through ``c`` and the radiance
    ``b`` of the pixel beyond it of the same surface, clamped to 1/2 .. 2 times ``c``; a
    pixel's own part (``shift`` < 0) keeps ``c`` where its shading rises toward the rim
    (the rgb sum of ``c`` at least ``b``'s)."""
    shift = np.asarray(shift, np.float64)[..., None]
    moved = np.clip(c + shift * (c - b), 0.5 * c, 2.0 * c)
    rises = (shift < 0) & (
        c[..., :3].sum(axis=-1, keepdims=True) >= b[..., :3].sum(axis=-1, keepdims=True)
    )
    return np.where(rises, c, moved)


def gbaa_radiance(
    hdr: np.ndarray, surface: np.ndarray, background: np.ndarray | None
) -> np.ndarray:
    """The HDR radiance the resolve reads at each pixel: ``hdr``'s, or ``background``
    (RGBA) at the pixels without a surface where it is given (a fused frame's HDR image
    holds the surfaces' radiance alone)."""
    hdr = np.asarray(hdr, np.float64)
    if background is None:
        return hdr
    return np.where((surface[..., 0] > 0)[..., None], hdr, np.asarray(background, np.float64))


def gbaa_resolve_radiance(
    surface: np.ndarray,
    edge: np.ndarray,
    hdr: np.ndarray,
    background: np.ndarray | None = None,
    exact: bool = False,
) -> np.ndarray:
    """(H, W, 4) the resolved linear HDR RGBA at every pixel (meaningful where
    ``gbaa_marked``): the pixel's own radiance (at its covered part's centroid, through
    the pixel opposite its edge where that holds its surface) over 1 - the neighbours'
    total weight, plus each neighbour's weight (scaled to 1 where they sum past it) of its
    radiance, the widest sliver's taken at its centroid (through the pixel two steps away
    where that holds the neighbour's surface). ``exact`` (a still's resolve, GBAA_EXACT):
    the areas ``gbaa_coverage``'s exact ones, and the own part corrected along the axes
    whose neighbours hold its surface (``gbaa_along_edge``)."""
    surface = np.asarray(surface, np.float64)
    radiance = gbaa_radiance(hdr, surface, background)
    weight, toward = gbaa_coverage(surface, edge, exact)
    around = [shifted(surface, dx, dy) for dx, dy in STEPS]
    colours = [shifted(radiance, dx, dy) for dx, dy in STEPS]
    total = weight.sum(axis=-1)
    scale = np.where(total > 1.0, 1.0 / np.maximum(total, 1e-300), 1.0)
    # own part: the pixel beyond it is the neighbour opposite ``toward``
    c = radiance.copy()
    for k in range(4):
        use = (toward == k) & gbaa_same_surface(surface, around[k ^ 1])
        moved = gbaa_centroid_radiance(radiance, colours[k ^ 1], -0.5 * weight[..., k])
        c = np.where(use[..., None], moved, c)
    if exact:
        c = c + gbaa_along_edge(radiance, surface, around, colours)
    c = c * (1.0 - np.minimum(total, 1.0))[..., None]
    # the widest sliver other than ``toward``'s (the first of a tie)
    widest = np.full(toward.shape, -1, np.int64)
    best = np.zeros(toward.shape)
    for k in range(4):
        take = (toward != k) & (weight[..., k] > 0) & ((widest < 0) | (weight[..., k] > best))
        widest = np.where(take, k, widest)
        best = np.where(take, weight[..., k], best)
    for k, (dx, dy) in enumerate(STEPS):
        sliver = colours[k]
        beyond = shifted(surface, 2 * dx, 2 * dy)
        use = (widest == k) & gbaa_same_surface(around[k], beyond)
        shift = 0.5 * (weight[..., k] + 1.0)  # (0.5 + d) / 2, d = weight + 0.5
        moved = gbaa_centroid_radiance(sliver, shifted(radiance, 2 * dx, 2 * dy), shift)
        sliver = np.where(use[..., None], moved, sliver)
        c = c + np.where((weight[..., k] > 0)[..., None], (weight[..., k] * scale)[..., None]
                         * sliver, 0.0)  # fmt: skip
    return c


def gbaa_display_value(
    c: np.ndarray, exposure_ev: float, tonemap: str, straight_alpha: bool = False
) -> np.ndarray:
    """(..., 4) the display value in 0..1 (unrounded) of linear HDR RGBA ``c``, as post
    writes it: exposed, tone-mapped and encoded; with ``straight_alpha`` the colour
    divided by the clamped alpha, which is written straight; else alpha 1."""
    c = np.asarray(c, np.float64)
    if straight_alpha:
        a = np.clip(c[..., 3:4], 0.0, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rgb = np.where(a > 0, c[..., :3] / a, 0.0)
        return np.concatenate([post_process(rgb, exposure_ev, tonemap), a], axis=-1)
    rgb = post_process(c[..., :3], exposure_ev, tonemap)
    return np.concatenate([rgb, np.ones_like(rgb[..., :1])], axis=-1)


def gbaa_resolve(
    surface: np.ndarray,
    edge: np.ndarray,
    hdr: np.ndarray,
    display: np.ndarray,
    exposure_ev: float,
    tonemap: str,
    straight_alpha: bool = False,
    background: np.ndarray | None = None,
    exact: bool = False,
    interior: bool = False,
) -> np.ndarray:
    """(H, W, 4) the display image after the resolve, in 0..1 (unrounded): at the marked
    pixels the resolved radiance's ``gbaa_display_value``, elsewhere ``display``'s bytes
    (post's image, RGBA8) / 255; ``exact``: ``gbaa_resolve_radiance``'s. ``interior``
    (``render.gbaa_interior``, GBAA_CORRECT): each surface pixel whose 4 neighbours
    hold its surface at its ``gbaa_interior_radiance``'s display value (colour and
    alpha: 1, or a transparent background's coverage, 1 at such a pixel in a frame)."""
    surface = np.asarray(surface, np.float64)
    c = gbaa_resolve_radiance(surface, edge, hdr, background, exact)
    out = np.asarray(display, np.float64) / 255.0
    marked = gbaa_marked(surface)
    if interior:
        radiance = gbaa_radiance(hdr, surface, background)
        n = [shifted(radiance, dx, dy) for dx, dy in STEPS]
        spill = GBAA_SPILL * gbaa_saturation(tonemap) / 2.0**exposure_ev
        mean = gbaa_display_value(gbaa_interior_radiance(radiance, n, spill), exposure_ev,
                                  tonemap, straight_alpha)  # fmt: skip
        inside = (surface[..., 0] > 0) & ~marked
        out = np.where(inside[..., None], mean, out)
    resolved = gbaa_display_value(c, exposure_ev, tonemap, straight_alpha)
    return np.where(marked[..., None], resolved, out)


# ---------------------------------------------------------------------------------------
# FXAA (glsl/passes/fxaa.frag)


def fxaa_luma(rgba: np.ndarray) -> np.ndarray:
    """Luma of display values (..., >= 3) in 0..1: the Rec. 601 weights of the encoded
    (not linear) colour, where edges are seen."""
    return np.asarray(rgba, np.float64)[..., :3] @ np.asarray(FXAA_LUMA)


def fxaa_search_step(i: int) -> float:
    """The search's step along the edge at step ``i`` in pixels (FXAA 3.11's preset 12)."""
    return 1.0 if i < 5 else 1.5 if i == 5 else 2.0 if i < 10 else 4.0 if i == 10 else 8.0


def fxaa_edge(luma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) bool, the pixels whose 4-neighbourhood luma contrast is an edge (at least
    ``FXAA_EDGE_THRESHOLD`` of the brightest and ``FXAA_EDGE_THRESHOLD_MIN``), and the
    contrast."""
    near = [luma] + [shifted(luma, dx, dy) for dx, dy in STEPS]
    hi, lo = np.max(near, axis=0), np.min(near, axis=0)
    contrast = hi - lo
    return contrast >= np.maximum(FXAA_EDGE_THRESHOLD_MIN, hi * FXAA_EDGE_THRESHOLD), contrast


def bilinear_luma(
    texels: np.ndarray, x: np.ndarray, y: np.ndarray, filtered_bytes: bool = True
) -> np.ndarray:
    """Luma of the bilinear texture read of RGBA8 ``texels`` (H, W, 4 bytes) at window
    positions ``x``, ``y`` (pixels, texel centres at i + 0.5), clamped to the border (a
    LINEAR, clamped sampler). ``filtered_bytes``: each lerp (along x, then y) rounded to
    8 bits, as llvmpipe filters an 8-bit texture (the GL leaves the filter's precision to
    the implementation; FXAA's reads fall on halves of a texel, where the exact mix of two
    bytes can lie half a byte from what llvmpipe returns); False: the exact mix."""
    h, w = texels.shape[:2]
    fx, fy = x - 0.5, y - 0.5
    x0, y0 = np.floor(fx), np.floor(fy)
    tx, ty = (fx - x0)[..., None], (fy - y0)[..., None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    xa, xb = np.clip(x0, 0, w - 1), np.clip(x0 + 1, 0, w - 1)
    ya, yb = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    rgb = np.asarray(texels, np.float64)[..., :3]

    def lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
        mixed = a + (b - a) * t
        return np.floor(mixed + 0.5) if filtered_bytes else mixed

    bottom = lerp(rgb[ya, xa], rgb[ya, xb], tx)
    top = lerp(rgb[yb, xa], rgb[yb, xb], tx)
    return fxaa_luma(lerp(bottom, top, ty) / 255.0)


def fxaa_filter(display: np.ndarray, filtered_bytes: bool = True) -> np.ndarray:
    """(H, W, 4) the filtered display image in 0..1 (unrounded) from ``display`` (RGBA8
    bytes): at each edge pixel (``fxaa_edge``) the direction from the 3x3 second
    differences, the walk both ways along the boundary with the steeper neighbour to where
    the luma leaves their mean by a quarter of the step, the offset 0.5 - the nearer end's
    distance over the span's (where that end's luma lies across the mean from the pixel's),
    at least the sub-pixel term's, and the pixel mixed with its neighbour across the edge
    by it in linear light, premultiplied by alpha; every other pixel as it was.
    ``filtered_bytes``: ``bilinear_luma``'s."""
    return fxaa_filter_with_ties(display, filtered_bytes)[0]


def fxaa_filter_with_ties(
    display: np.ndarray, filtered_bytes: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """``fxaa_filter``'s image and (H, W) each pixel's tie margin: the smallest difference
    between the two sides of any comparison that decided the pixel (the edge test, the
    direction, the steeper side, each step's end test, the end's side of the mean; inf
    where none did). Where it is 0 the GL's float32 rounding, not the equation, decides."""
    src = np.asarray(display, np.float64) / 255.0
    texels = np.asarray(display, np.float64)
    h, w = src.shape[:2]
    luma = fxaa_luma(src)
    edge, contrast = fxaa_edge(luma)
    margin = np.full((h, w), np.inf)
    threshold = np.maximum(FXAA_EDGE_THRESHOLD_MIN, np.maximum.reduce(
        [luma] + [shifted(luma, dx, dy) for dx, dy in STEPS]) * FXAA_EDGE_THRESHOLD)  # fmt: skip
    margin = np.minimum(margin, np.abs(contrast - threshold))
    out = src.copy()
    ys, xs = np.nonzero(edge)
    if ys.size == 0:
        return out, margin
    m = luma[ys, xs]

    def at(dx: int, dy: int) -> np.ndarray:
        return luma[np.clip(ys + dy, 0, h - 1), np.clip(xs + dx, 0, w - 1)]

    n, s, e, wl = at(0, 1), at(0, -1), at(1, 0), at(-1, 0)
    nw, ne, sw, se = at(-1, 1), at(1, 1), at(-1, -1), at(1, -1)
    across_y = np.abs(nw - 2 * wl + sw) + 2 * np.abs(n - 2 * m + s) + np.abs(ne - 2 * e + se)
    across_x = np.abs(nw - 2 * n + ne) + 2 * np.abs(wl - 2 * m + e) + np.abs(sw - 2 * s + se)
    horizontal = across_y >= across_x
    l_neg, l_pos = np.where(horizontal, s, wl), np.where(horizontal, n, e)
    g_neg, g_pos = np.abs(l_neg - m), np.abs(l_pos - m)
    negative = g_neg >= g_pos
    side = np.where(negative, -1.0, 1.0)  # the steeper neighbour, across the edge
    local = np.where(negative, 0.5 * (l_neg + m), 0.5 * (l_pos + m))
    gradient = 0.25 * np.maximum(g_neg, g_pos)
    tie = np.minimum(np.abs(across_y - across_x), np.abs(g_neg - g_pos))
    tie = np.minimum(tie, np.abs(m - local))
    # window positions: the pixel's centre, moved half a pixel onto the boundary
    cx, cy = xs + 0.5, ys + 0.5
    ex = np.where(horizontal, cx, cx + 0.5 * side)
    ey = np.where(horizontal, cy + 0.5 * side, cy)
    ax, ay = np.where(horizontal, 1.0, 0.0), np.where(horizontal, 0.0, 1.0)  # along
    x1, y1, x2, y2 = ex - ax, ey - ay, ex + ax, ey + ay
    e1 = bilinear_luma(texels, x1, y1, filtered_bytes) - local
    e2 = bilinear_luma(texels, x2, y2, filtered_bytes) - local
    tie = np.minimum(tie, np.minimum(np.abs(np.abs(e1) - gradient), np.abs(np.abs(e2) - gradient)))
    done1, done2 = np.abs(e1) >= gradient, np.abs(e2) >= gradient
    for i in range(1, FXAA_STEPS):
        step = fxaa_search_step(i)
        go1, go2 = ~done1, ~done2
        x1, y1 = np.where(go1, x1 - ax * step, x1), np.where(go1, y1 - ay * step, y1)
        e1 = np.where(go1, bilinear_luma(texels, x1, y1, filtered_bytes) - local, e1)
        done1 = done1 | (np.abs(e1) >= gradient)
        x2, y2 = np.where(go2, x2 + ax * step, x2), np.where(go2, y2 + ay * step, y2)
        e2 = np.where(go2, bilinear_luma(texels, x2, y2, filtered_bytes) - local, e2)
        done2 = done2 | (np.abs(e2) >= gradient)
        tie = np.minimum(tie, np.where(go1, np.abs(np.abs(e1) - gradient), np.inf))
        tie = np.minimum(tie, np.where(go2, np.abs(np.abs(e2) - gradient), np.inf))
    d1 = np.where(horizontal, cx - x1, cy - y1)
    d2 = np.where(horizontal, x2 - cx, y2 - cy)
    nearer1 = d1 < d2
    offset = 0.5 - np.minimum(d1, d2) / (d1 + d2)
    end = np.where(nearer1, e1, e2)
    tie = np.minimum(tie, np.where(offset > 0, np.abs(end), np.inf))
    valid = (end < 0) != (m < local)
    offset = np.where(valid, offset, 0.0)
    low = (2 * (n + s + e + wl) + (nw + ne + sw + se)) / 12.0
    sub = np.clip(np.abs(low - m) / contrast[ys, xs], 0.0, 1.0)
    sub = (-2 * sub + 3) * sub * sub
    offset = np.maximum(offset, sub * sub * FXAA_SUBPIX)
    ox = np.where(horizontal, 0, side).astype(np.int64)
    oy = np.where(horizontal, side, 0).astype(np.int64)
    centre = src[ys, xs]
    other = src[np.clip(ys + oy, 0, h - 1), np.clip(xs + ox, 0, w - 1)]
    t = offset[:, None]
    alpha = centre[:, 3] + (other[:, 3] - centre[:, 3]) * offset
    lin_c = srgb_decode(centre[:, :3]) * centre[:, 3:4]
    lin_o = srgb_decode(other[:, :3]) * other[:, 3:4]
    rgb = lin_c + (lin_o - lin_c) * t
    with np.errstate(divide="ignore", invalid="ignore"):
        rgb = np.where(alpha[:, None] > 0, rgb / alpha[:, None], 0.0)
    out[ys, xs, :3] = srgb_encode(rgb)
    out[ys, xs, 3] = alpha
    margin[ys, xs] = np.minimum(margin[ys, xs], tie)
    return out, margin


# ---------------------------------------------------------------------------------------
# jittered accumulation (glsl/passes/accumulate.frag, app/render/antialias.py)


def halton(index: int, base: int) -> float:
    """The radical inverse of ``index`` >= 1 in ``base`` (J. H. Halton, 1964)."""
    f, r = 1.0, 0.0
    while index > 0:
        f /= base
        r += f * (index % base)
        index //= base
    return r


def jitter_offsets(n: int) -> np.ndarray:
    """(n, 2) the sub-pixel offsets of the n jittered frames in pixels: the Halton (2, 3)
    points 1..n, moved together so that their mean is the pixel's centre."""
    points = np.array([(halton(k, 2), halton(k, 3)) for k in range(1, n + 1)], np.float64)
    return points - points.mean(axis=0)


def accumulate(samples: np.ndarray) -> np.ndarray:
    """(N, H, W, 4) -> (N, H, W, 4): after each sample k the running mean the pass holds,
    mean_k = mean_{k-1} + (sample_k - mean_{k-1}) / (k + 1), mean_0 = sample_0 (alpha
    averaged with the colour: premultiplied stays premultiplied); the last is the mean
    of all N, which post tone-maps once."""
    samples = np.asarray(samples, np.float64)
    means = np.empty_like(samples)
    mean = samples[0]
    for k, sample in enumerate(samples):
        mean = mean + (sample - mean) * (1.0 / (k + 1))
        means[k] = mean
    return means


# ---------------------------------------------------------------------------------------
# subpixel reconstruction (glsl/passes/sraa.frag, app/render/antialias.py SraaPass)

# sraa.frag's u_depth_tolerance (app/render/antialias.py SRAA_DEPTH_TOLERANCE): a sample
# and a pixel centre on one material see one surface within this fraction of the
# sample's view depth
SRAA_DEPTH_TOLERANCE = 0.1


def sraa_same_surface(
    centre: np.ndarray, sample: np.ndarray, tolerance: float = SRAA_DEPTH_TOLERANCE
) -> np.ndarray:
    """Whether RT2 texels ``centre`` and ``sample`` (..., 2: view depth, 0 the background;
    material id) saw the same surface (sraa.frag's ``same_surface``): both the background,
    or neither and one material id at view depths within ``tolerance`` of the sample's."""
    dc, ds = centre[..., 0], sample[..., 0]
    either_background = (dc == 0) | (ds == 0)
    same = (centre[..., 1] == sample[..., 1]) & (np.abs(dc - ds) <= tolerance * ds)
    return np.where(either_background, (dc == 0) & (ds == 0), same)


def sraa_edges(
    surface: np.ndarray, samples: np.ndarray, tolerance: float = SRAA_DEPTH_TOLERANCE
) -> np.ndarray:
    """(H, W) bool: the pixels the mark draw marks, those with a geometry sample (``samples``
    (H, W, S, 2), the multisampled RT2) on another surface than the centre's RT2
    (``surface`` (H, W, 2))."""
    return ~np.all(sraa_same_surface(surface[:, :, None], samples, tolerance), axis=-1)


def sraa_resolve(
    hdr: np.ndarray,
    surface: np.ndarray,
    samples: np.ndarray,
    tolerance: float = SRAA_DEPTH_TOLERANCE,
) -> np.ndarray:
    """(H, W, 4) the pass's target from the pixel-centre frame's linear HDR RGBA ``hdr``
    (H, W, 4), its RT2 ``surface`` (H, W, 2) and the geometry samples' RT2 ``samples``
    (H, W, S, 2). A sample on the centre's surface takes the pixel's own colour; another
    takes that of the pixel among its own and its eight neighbours (clamped to the image)
    whose centre saw the sample's surface, the nearest in view depth, the first in
    sraa.frag's order (rows bottom-up, then left to right) on a tie, the pixel's own where
    none did. Edge pixels (``sraa_edges``) hold the mean of the centre and the samples,
    every other pixel its own colour, copied (Chajdas, McGuire and Luebke 2011)."""
    hdr = np.asarray(hdr, np.float64)
    surface = np.asarray(surface, np.float64)
    samples = np.asarray(samples, np.float64)
    total = hdr.copy()
    for s in range(samples.shape[2]):
        gs = samples[:, :, s]
        search = ~sraa_same_surface(surface, gs, tolerance)
        colour = hdr.copy()
        best = np.full(hdr.shape[:2], 1e30)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                gq = shifted(surface, dx, dy)
                distance = np.abs(gq[..., 0] - gs[..., 0])
                nearer = search & sraa_same_surface(gq, gs, tolerance) & (distance < best)
                best = np.where(nearer, distance, best)
                colour = np.where(nearer[..., None], shifted(hdr, dx, dy), colour)
        total += colour
    mean = total / (samples.shape[2] + 1)
    return np.where(sraa_edges(surface, samples, tolerance)[..., None], mean, hdr)
