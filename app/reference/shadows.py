"""Float64 twin of glsl/lights/shadows.glsl: a shadowed light's visibility at a point,
read from the shadow maps' depth atlas as the lighting pass reads it (RTR4 §7.4).

The GPU renders the maps (app/render/shadows.py) and this module reads them back, so the
comparison of the lighting pass with ``shade_gbuffer`` isolates the lookup's float32
arithmetic, as it does for the BRDF. The reference for where shadows *should* fall is not
this twin but the ray-caster's exact shadow rays (app/reference/raycast.py
``light_visibility``; docs/shadows.md measures the maps against them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.common.lights import PunctualLight


@dataclass(frozen=True)
class ShadowMaps:
    """What the lighting pass's SHADOWS uniforms and atlas hold (glsl/lights/shadows.glsl):
    per map k the light it belongs to, its world -> clip matrix, its rectangle in the atlas
    (first texel x, y, size, 1 for PCF, 2 for PCSS), its normal offset (metres, or metres
    per metre of distance, and 1 for a perspective map) and its PCSS constants (light size,
    near, far or 0 and depth extent, texel size)."""

    depth: np.ndarray  # (H, W) float64 window depths, row 0 the atlas's bottom (as texelFetch)
    lights: tuple[int, ...]
    matrices: tuple[np.ndarray, ...]  # (4, 4) float64 each
    rects: tuple[tuple[float, float, float, float], ...]
    offsets: tuple[tuple[float, float], ...]
    pcss: tuple[tuple[float, float, float, float], ...] = ()
    # the lighting pass offsets along the depths' plane (a receiver's normal is mapped:
    # SHADOW_FACE_NORMAL, ``face_normals``), else along the G-buffer's normal
    face_normal: bool = False
    # the glass target beside the atlas where the frame has transmissive parts
    # (SHADOW_GLASS): (H, W, 4) float64, rgb the product of the glass transmittances in
    # front of the opaque depth, alpha the nearest glass window depth (1 where none), row 0
    # the bottom; with it every visibility is a colour, (N, 3)
    glass: np.ndarray | None = None


# PCSS's taps (blocker search, variable PCF) and widest radius in texels, as the GLSL's.
PCSS_SEARCH_TAPS = 16
PCSS_FILTER_TAPS = 32
PCSS_MAX_RADIUS = 32.0
GOLDEN_ANGLE = 2.39996323  # radians, pi (3 - sqrt 5) to the GLSL's float


def vogel_tap(i: int, n: int) -> np.ndarray:
    """(2,) tap ``i`` of ``n`` on the unit disc, equal areas (Vogel 1979, "A better way to
    construct the sunflower head"): radius sqrt((i + 0.5) / n), angle i golden angles."""
    r = np.sqrt((i + 0.5) / n)
    a = i * GOLDEN_ANGLE
    return r * np.array([np.cos(a), np.sin(a)])


def orthographic(maps: ShadowMaps, k: int) -> bool:
    """Map ``k`` is orthographic: a directional light's map or one of its cascades."""
    kind = maps.offsets[k][1]
    return kind < 0.5 or kind > 2.5


# A cascade holds a point this many texels inside its edges (the filter's taps stay in it).
CASCADE_MARGIN = 3.0


def in_cascade(maps: ShadowMaps, k: int, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(N,) bool: points ``p`` moved by their normal offset lie in cascade ``k``'s map,
    ``CASCADE_MARGIN`` texels inside its edges, and within its depth (glsl in_cascade)."""
    m = np.asarray(maps.matrices[k], np.float64)
    q = p + n * maps.offsets[k][0]
    clip = q @ m[:3, :3].T + m[:3, 3]
    w = q @ m[3, :3] + m[3, 3]
    ndc = clip / w[:, None]
    edge = 1.0 - 2.0 * CASCADE_MARGIN / maps.rects[k][2]
    return np.all(np.abs(ndc[:, :2]) <= edge, axis=1) & (np.abs(ndc[:, 2]) <= 1.0)


def shadow_linear_depth(maps: ShadowMaps, k: int, z: np.ndarray) -> np.ndarray:
    """Window depth ``z`` of map ``k`` as metres from the light (perspective: along the
    axis) or from the orthographic map's near plane."""
    _, near, far, _ = maps.pcss[k]
    if orthographic(maps, k):
        return z * far
    return near * far / (far - z * (far - near))


def shadow_map_coords(maps: ShadowMaps, k: int, q: np.ndarray) -> np.ndarray:
    """(N, 3): texel position within map ``k`` and window depth of world points ``q``."""
    m = np.asarray(maps.matrices[k], np.float64)
    clip = q @ m[:3, :3].T + m[:3, 3]
    w = q @ m[3, :3] + m[3, 3]
    ndc = clip / w[:, None]
    size = maps.rects[k][2]
    return np.concatenate([(ndc[:, :2] * 0.5 + 0.5) * size, ndc[:, 2:] * 0.5 + 0.5], axis=1)


def pcss_visibility(
    maps: ShadowMaps, k: int, q: np.ndarray, n: np.ndarray, pos: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """(N,) PCSS visibility (Fernando 2005, "Percentage-Closer Soft Shadows") of points
    ``q`` (after the normal offset) with normals ``n``, at texel positions ``pos`` and
    window depths ``z`` of map ``k``: the blocker search, the penumbra's half width
    w = (d_r - d_b) light_size / d_b (perspective) or (d_r - d_b) tan(angle)
    (orthographic), and a bilinear PCF over a disc of that radius, each texel compared
    with the receiver's plane (receiver-plane depth bias, Isidoro 2006), in the GLSL's
    order (glsl/lights/shadows.glsl pcss_visibility)."""
    size_l, near, _, texel_c = maps.pcss[k]
    x0, y0, size, _ = maps.rects[k]
    lo = np.array([int(x0), int(y0)])
    hi = lo + int(size) - 1
    ortho = orthographic(maps, k)
    d_r = shadow_linear_depth(maps, k, z)
    texel = texel_c * (np.ones_like(d_r) if ortho else d_r)
    a = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    here = np.concatenate([pos, z[:, None]], axis=1)
    m1 = shadow_map_coords(maps, k, q + t1 * texel[:, None]) - here
    m2 = shadow_map_coords(maps, k, q + t2 * texel[:, None]) - here
    det = m1[:, 0] * m2[:, 1] - m1[:, 1] * m2[:, 0]
    ok = np.abs(det) > 1e-6
    safe = np.where(ok, det, 1.0)
    g = (
        np.stack(
            [m2[:, 1] * m1[:, 2] - m1[:, 1] * m2[:, 2], m1[:, 0] * m2[:, 2] - m2[:, 0] * m1[:, 2]],
            axis=1,
        )
        / safe[:, None]
    )
    g[~ok] = 0.0
    depth = maps.depth

    def plane_z(t: np.ndarray) -> np.ndarray:
        centre = (t - lo) + 0.5
        return z + np.sum(g * (centre - pos), axis=1)

    def clamp(t: np.ndarray) -> np.ndarray:
        return np.clip(t, lo, hi)

    # every blocker that can hide part of the light lies within this many texels
    far_reach = size_l * (d_r - near) / (near * d_r * texel_c) if not ortho else 0.0
    reach = d_r * size_l / texel_c if ortho else far_reach
    search = np.clip(reach, 1.0, PCSS_MAX_RADIUS)
    blockers = np.zeros(len(z))
    d_sum = np.zeros(len(z))
    for i in range(PCSS_SEARCH_TAPS):
        t = clamp(
            lo + np.floor(pos + search[:, None] * vogel_tap(i, PCSS_SEARCH_TAPS)).astype(np.int64)
        )
        stored = depth[t[:, 1], t[:, 0]]
        hit = stored < plane_z(t)
        blockers += hit
        d_sum += np.where(hit, shadow_linear_depth(maps, k, stored), 0.0)
    out = np.ones(len(z))
    found = blockers > 0.0
    d_b = d_sum / np.maximum(blockers, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (d_r - d_b) * size_l if ortho else (d_r - d_b) * size_l / d_b
    radius = np.clip(np.where(found, w / texel, 1.0), 1.0, PCSS_MAX_RADIUS)
    total = np.zeros(len(z))
    for i in range(PCSS_FILTER_TAPS):
        sp = pos + radius[:, None] * vogel_tap(i, PCSS_FILTER_TAPS) - 0.5
        cell = np.floor(sp)
        f = sp - cell
        b = lo + cell.astype(np.int64)
        v = [
            np.where(
                plane_z(clamp(b + d)) <= depth[clamp(b + d)[:, 1], clamp(b + d)[:, 0]], 1.0, 0.0
            )
            for d in (np.array([0, 0]), np.array([1, 0]), np.array([0, 1]), np.array([1, 1]))
        ]
        lower = v[0] + (v[1] - v[0]) * f[:, 0]
        upper = v[2] + (v[3] - v[2]) * f[:, 0]
        total += lower + (upper - lower) * f[:, 1]
    out[found] = total[found] / PCSS_FILTER_TAPS
    return out


def pcf_weights(f: np.ndarray) -> np.ndarray:
    """(..., 4) weights, times 3, of the four texels from the one below ``pos - 0.5``
    minus 1: a 3 x 3 box of bilinear taps one texel apart sums to ((1 - f), 1, 1, f) / 3
    along each axis (the GLSL divides the 2D sum by 9 once)."""
    one = np.ones_like(f)
    return np.stack([1.0 - f, one, one, f], axis=-1)


def glass_transmittance_at(
    glass: np.ndarray, lo: np.ndarray, hi: np.ndarray, pos: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """(N, 3) the glass target's transmittance at texel positions ``pos`` (N, 2) of the map
    whose texels are ``lo`` .. ``hi``, for receivers at window depths ``z`` (N,): each of
    the four texels around ``pos`` its product where the receiver lies behind its nearest
    glass, else 1 (lit glass does not shadow itself), bilinearly weighted, as
    glass_transmittance_at in glsl/lights/shadows.glsl reads it (a soft tinted edge)."""
    qpos = pos - 0.5
    cell = np.floor(qpos)
    f = qpos - cell
    base = lo + cell.astype(np.int64)

    def texel(dx: int, dy: int) -> np.ndarray:
        tx = np.clip(base[:, 0] + dx, lo[0], hi[0])
        ty = np.clip(base[:, 1] + dy, lo[1], hi[1])
        g = glass[ty, tx]
        return np.where((z > g[:, 3])[:, None], g[:, :3], 1.0)

    fx, fy = f[:, :1], f[:, 1:]
    bottom = texel(0, 0) + (texel(1, 0) - texel(0, 0)) * fx
    top = texel(0, 1) + (texel(1, 1) - texel(0, 1)) * fx
    return bottom + (top - bottom) * fy


def map_positions(
    maps: ShadowMaps, k: int, p: np.ndarray, n: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the lookup of map ``k`` reaches the map for points ``p`` (N, 3) with normals
    ``n``, in the GLSL's order (shadow_map_visibility): ``q`` (N, 3) the points moved by
    the normal offset, ``inside`` (N,) those that reach the map (not behind a spot, within
    its depth and, but for a cube face, which keeps its edge texels, its square), and for
    those (M,) their texel positions within the map (M, 2) and window depths (M,)."""
    m = np.asarray(maps.matrices[k], np.float64)
    p = np.asarray(p, np.float64)
    n = np.asarray(n, np.float64)
    offset, kind = maps.offsets[k]  # kind: 0 orthographic, 1 spot, 2 cube face
    w = p @ m[3, :3] + m[3, 3]
    scale = w if kind > 0.5 else np.ones_like(w)
    q = p + n * (offset * scale)[:, None]
    clip = q @ m[:3, :3].T + m[:3, 3]
    w = q @ m[3, :3] + m[3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = clip / w[:, None]
    # a cube face (chosen to hold p) keeps a point its normal offset moved past its edge
    outside_xy = np.any(np.abs(ndc[:, :2]) > 1.0, axis=-1) & (kind < 1.5)
    inside = (w > 0.0) & (np.abs(ndc[:, 2]) <= 1.0) & ~outside_xy
    ndc = ndc[inside]
    size = maps.rects[k][2]
    pos = (ndc[:, :2] * 0.5 + 0.5) * size  # within the map; the atlas offset is lo
    return q, inside, pos, ndc[:, 2] * 0.5 + 0.5


def shadow_map_visibility(maps: ShadowMaps, k: int, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(N,) visibility through map ``k`` of points ``p`` (N, 3) with normals ``n``: the
    normal offset, the projection (``map_positions``), and the nearest texel's or the PCF
    kernel's comparisons, in the GLSL's order (shadow_map_visibility). With
    ``maps.glass``, (N, 3): that visibility times the glass's transmittance at the same
    position and depth (``glass_transmittance_at``; 1 where the lookup does not reach the
    map), as shadow_prepare multiplies them."""
    q, inside, pos, z = map_positions(maps, k, p, n)
    out = np.ones(len(q))
    if np.any(inside):
        out[inside] = _depth_visibility(maps, k, q[inside], np.asarray(n)[inside], pos, z)
    if maps.glass is None:
        return out
    tint = np.ones((len(q), 3))
    if np.any(inside):
        x0, y0, size, _ = maps.rects[k]
        lo = np.array([int(x0), int(y0)])
        tint[inside] = glass_transmittance_at(maps.glass, lo, lo + int(size) - 1, pos, z)
    return out[:, None] * tint


def _depth_visibility(
    maps: ShadowMaps, k: int, q: np.ndarray, n: np.ndarray, pos: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """(M,) the depth atlas's visibility of the points that reach map ``k`` (``q`` moved by
    the normal offset, ``pos`` their texel positions, ``z`` their window depths): the
    nearest texel's comparison, PCSS's, or the PCF kernel's."""
    x0, y0, size, pcf = maps.rects[k]
    lo = np.array([int(x0), int(y0)])
    hi = lo + int(size) - 1
    depth = maps.depth

    def test(tx: np.ndarray, ty: np.ndarray) -> np.ndarray:
        tx, ty = np.clip(tx, lo[0], hi[0]), np.clip(ty, lo[1], hi[1])
        return np.where(z <= depth[ty, tx], 1.0, 0.0)

    if pcf < 0.5:
        texel = lo + np.floor(pos).astype(np.int64)
        return test(texel[:, 0], texel[:, 1])
    if pcf > 1.5:
        return pcss_visibility(maps, k, q, n, pos, z)
    qpos = pos - 0.5
    cell = np.floor(qpos)
    f = qpos - cell
    base = lo + cell.astype(np.int64)
    wx, wy = pcf_weights(f[:, 0]), pcf_weights(f[:, 1])
    total = np.zeros(len(z))
    for j in range(4):
        for i in range(4):
            total += wx[:, i] * wy[:, j] * test(base[:, 0] + i - 1, base[:, 1] + j - 1)
    return total / 9.0


def cube_face(d: np.ndarray) -> np.ndarray:
    """(N,) face index 0..5 (+x, -x, +y, -y, +z, -z) along the major axis of ``d`` (N, 3),
    the direction from a point light to the points; ties go to x, then y, as in the GLSL."""
    a = np.abs(d)
    axis = np.where(
        (a[:, 0] >= a[:, 1]) & (a[:, 0] >= a[:, 2]), 0, np.where(a[:, 1] >= a[:, 2], 1, 2)
    )
    negative = np.take_along_axis(d, axis[:, None], axis=1)[:, 0] < 0.0
    return 2 * axis + negative


def _unshadowed(maps: ShadowMaps, count: int) -> np.ndarray:
    """The visibility of ``count`` points before any map is read: (count,) ones, or
    (count, 3) with the glass target (a colour)."""
    return np.ones((count, 3) if maps.glass is not None else count)


def light_visibilities(
    maps: ShadowMaps | None, lights: list[PunctualLight], p: np.ndarray, n: np.ndarray
) -> list[np.ndarray | None]:
    """Per light: its map's visibility at ``p`` (for a point light, per point, the cube
    face ``cube_face`` picks), or None for a light without one (glsl/lights/shadows.glsl
    shadow_visibility; ``illumination_sum``'s argument): (N,), or (N, 3) coloured by the
    glass in front where ``maps.glass`` is read back (SHADOW_GLASS)."""
    out: list[np.ndarray | None] = [None] * len(lights)
    if maps is None:
        return out
    p = np.asarray(p, np.float64)
    for k, i in enumerate(maps.lights):
        if out[i] is not None:  # the other faces of a point light, done with its first
            continue
        if maps.offsets[k][1] > 2.5:  # cascades k, k + 1, ...: the first that holds p
            n = np.asarray(n, np.float64)
            cascades = [c for c in range(k, len(maps.lights)) if maps.lights[c] == i]
            choice = np.full(len(p), cascades[-1])
            left = np.ones(len(p), bool)
            for c in cascades:
                take = left & in_cascade(maps, c, p, n)
                choice[take] = c
                left &= ~take
            v = _unshadowed(maps, len(p))
            for c in cascades:
                sel = choice == c
                if np.any(sel):
                    v[sel] = shadow_map_visibility(maps, c, p[sel], n[sel])
            out[i] = v
            continue
        if maps.offsets[k][1] < 1.5:
            out[i] = shadow_map_visibility(maps, k, p, n)
            continue
        face = cube_face(p - np.asarray(lights[i].position, np.float64))
        v = _unshadowed(maps, len(p))
        for f in range(6):
            sel = face == f
            if np.any(sel):
                v[sel] = shadow_map_visibility(maps, k + f, p[sel], np.asarray(n)[sel])
        out[i] = v
    return out


def face_normals(
    depth: np.ndarray,
    camera_to_world: np.ndarray,
    tan_half_fov: tuple[float, float],
    v: np.ndarray,
    n: np.ndarray,
) -> np.ndarray:
    """(C, 3) the geometric normals of the covered pixels (``depth`` > 0 and finite, (H, W)
    view depths, row 0 at the top), row-major as ``v`` and ``n`` (C, 3): the shadow
    lookup's offset direction, twin of glsl/gbuffer/decode.glsl ``face_normal``. The plane
    through the view-space points of a pixel and, per image axis, the neighbour nearer in
    depth (a tie takes +x, +y, i.e. the row above), the background and the image's outside
    not taken; facing ``v``; ``n`` where an axis has no neighbour or its two neighbours'
    depth steps differ by more than a factor 3 and 1e-4 of the depth (a depth edge beside
    the pixel)."""
    z = np.asarray(depth, np.float64)
    h, w = z.shape
    valid = np.isfinite(z) & (z > 0.0)
    zs = np.where(valid, z, 0.0)
    xs = (np.arange(w) + 0.5) / w * 2.0 - 1.0
    ys = 1.0 - (np.arange(h) + 0.5) / h * 2.0
    tx, ty = tan_half_fov
    points = np.stack(
        np.broadcast_arrays(zs * xs[None, :] * tx, zs * ys[:, None] * ty, -zs), axis=-1
    )
    # padded by one invalid pixel all round: a neighbour outside the image is not taken
    zp = np.pad(zs, 1)
    okp = np.pad(valid, 1)
    pp = np.pad(points, ((1, 1), (1, 1), (0, 0)))
    rows, cols = np.nonzero(valid)
    r, c = rows + 1, cols + 1
    here = pp[r, c]
    z0 = zp[r, c]
    edges = []
    missing = np.zeros(len(r), bool)
    for (ra, ca), (rb, cb) in (((r, c + 1), (r, c - 1)), ((r - 1, c), (r + 1, c))):
        ok_a, ok_b = okp[ra, ca], okp[rb, cb]
        da, db = np.abs(zp[ra, ca] - z0), np.abs(z0 - zp[rb, cb])
        edge = ok_a & ok_b & (np.abs(da - db) > 0.5 * (da + db) + 1e-4 * z0)
        missing |= (~ok_a & ~ok_b) | edge
        take_a = ok_a & (~ok_b | (da <= db))
        edges.append(np.where(take_a[:, None], pp[ra, ca] - here, here - pp[rb, cb]))
    m = np.asarray(camera_to_world, np.float64)
    g = np.cross(edges[0] @ m.T, edges[1] @ m.T)
    length = np.linalg.norm(g, axis=-1)
    good = ~missing & np.isfinite(length) & (length > 0.0)
    g = g / np.where(good, length, 1.0)[:, None]
    g = np.where((np.sum(g * v, axis=-1) < 0.0)[:, None], -g, g)
    return np.where(good[:, None], g, np.asarray(n, np.float64))
