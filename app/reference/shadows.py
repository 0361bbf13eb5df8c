"""Float64 twin of glsl/lights/shadows.glsl: a shadowed light's visibility at a point,
read from the shadow maps' depth atlas as the lighting pass reads it (RTR4 §7.4; issue 18).

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
    (first texel x, y, size, 1 for PCF) and its normal offset (metres, or metres per metre
    of distance, and 1 for a perspective map)."""

    depth: np.ndarray  # (H, W) float64 window depths, row 0 the atlas's bottom (as texelFetch)
    lights: tuple[int, ...]
    matrices: tuple[np.ndarray, ...]  # (4, 4) float64 each
    rects: tuple[tuple[float, float, float, float], ...]
    offsets: tuple[tuple[float, float], ...]


def pcf_weights(f: np.ndarray) -> np.ndarray:
    """(..., 4) weights, times 3, of the four texels from the one below ``pos - 0.5``
    minus 1: a 3 x 3 box of bilinear taps one texel apart sums to ((1 - f), 1, 1, f) / 3
    along each axis (the GLSL divides the 2D sum by 9 once)."""
    one = np.ones_like(f)
    return np.stack([1.0 - f, one, one, f], axis=-1)


def shadow_map_visibility(maps: ShadowMaps, k: int, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(N,) visibility through map ``k`` of points ``p`` (N, 3) with normals ``n``: the
    normal offset, the projection, and the nearest texel's or the PCF kernel's
    comparisons, in the GLSL's order (shadow_map_visibility)."""
    m = np.asarray(maps.matrices[k], np.float64)
    p = np.asarray(p, np.float64)
    n = np.asarray(n, np.float64)
    offset, kind = maps.offsets[k]  # kind: 0 orthographic, 1 spot, 2 cube face
    clip = p @ m[:3, :3].T + m[:3, 3]
    w = p @ m[3, :3] + m[3, 3]
    scale = w if kind > 0.5 else np.ones_like(w)
    q = p + n * (offset * scale)[:, None]
    clip = q @ m[:3, :3].T + m[:3, 3]
    w = q @ m[3, :3] + m[3, 3]
    out = np.ones(len(p))
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = clip / w[:, None]
    # a cube face (chosen to hold p) keeps a point its normal offset moved past its edge
    outside_xy = np.any(np.abs(ndc[:, :2]) > 1.0, axis=-1) & (kind < 1.5)
    inside = (w > 0.0) & (np.abs(ndc[:, 2]) <= 1.0) & ~outside_xy
    if not np.any(inside):
        return out
    ndc = ndc[inside]
    z = ndc[:, 2] * 0.5 + 0.5
    x0, y0, size, pcf = maps.rects[k]
    pos = (ndc[:, :2] * 0.5 + 0.5) * size  # within the map; the atlas offset is lo
    lo = np.array([int(x0), int(y0)])
    hi = lo + int(size) - 1
    depth = maps.depth

    def test(tx: np.ndarray, ty: np.ndarray) -> np.ndarray:
        tx, ty = np.clip(tx, lo[0], hi[0]), np.clip(ty, lo[1], hi[1])
        return np.where(z <= depth[ty, tx], 1.0, 0.0)

    if pcf < 0.5:
        texel = lo + np.floor(pos).astype(np.int64)
        out[inside] = test(texel[:, 0], texel[:, 1])
        return out
    qpos = pos - 0.5
    cell = np.floor(qpos)
    f = qpos - cell
    base = lo + cell.astype(np.int64)
    wx, wy = pcf_weights(f[:, 0]), pcf_weights(f[:, 1])
    total = np.zeros(len(z))
    for j in range(4):
        for i in range(4):
            total += wx[:, i] * wy[:, j] * test(base[:, 0] + i - 1, base[:, 1] + j - 1)
    out[inside] = total / 9.0
    return out


def cube_face(d: np.ndarray) -> np.ndarray:
    """(N,) face index 0..5 (+x, -x, +y, -y, +z, -z) along the major axis of ``d`` (N, 3),
    the direction from a point light to the points; ties go to x, then y, as in the GLSL."""
    a = np.abs(d)
    axis = np.where(
        (a[:, 0] >= a[:, 1]) & (a[:, 0] >= a[:, 2]), 0, np.where(a[:, 1] >= a[:, 2], 1, 2)
    )
    negative = np.take_along_axis(d, axis[:, None], axis=1)[:, 0] < 0.0
    return 2 * axis + negative


def light_visibilities(
    maps: ShadowMaps | None, lights: list[PunctualLight], p: np.ndarray, n: np.ndarray
) -> list[np.ndarray | None]:
    """Per light: its map's visibility at ``p`` (for a point light, per point, the cube
    face ``cube_face`` picks), or None for a light without one (glsl/lights/shadows.glsl
    shadow_visibility; ``illumination_sum``'s argument)."""
    out: list[np.ndarray | None] = [None] * len(lights)
    if maps is None:
        return out
    p = np.asarray(p, np.float64)
    for k, i in enumerate(maps.lights):
        if out[i] is not None:  # the other faces of a point light, done with its first
            continue
        if maps.offsets[k][1] < 1.5:
            out[i] = shadow_map_visibility(maps, k, p, n)
            continue
        face = cube_face(p - np.asarray(lights[i].position, np.float64))
        v = np.ones(len(p))
        for f in range(6):
            sel = face == f
            if np.any(sel):
                v[sel] = shadow_map_visibility(maps, k + f, p[sel], np.asarray(n)[sel])
        out[i] = v
    return out
