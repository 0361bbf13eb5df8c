"""Twin of glsl/env/equirect.glsl: the equirectangular map's direction convention, and
the bilinear lookup GL's LINEAR filter does (u repeats, v clamps), in float64."""

from __future__ import annotations

import math

import numpy as np


def rotate_y(d: np.ndarray, radians: float) -> np.ndarray:
    """Directions ``d`` (..., 3) turned ``radians`` about +Y (right-handed: +Z to +X)."""
    c, s = math.cos(radians), math.sin(radians)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([c * x + s * z, y, -s * x + c * z], axis=-1)


def env_map_direction(d: np.ndarray, rotation: float) -> np.ndarray:
    """World directions ``d`` (..., 3) in the frame of a map turned ``rotation`` radians
    about +Y."""
    return rotate_y(np.asarray(d, np.float64), -rotation)


def equirect_uv(d: np.ndarray, rotation: float) -> np.ndarray:
    """(u, v) (..., 2) of world directions ``d`` in a map turned ``rotation`` radians about
    +Y: u = 1/2 + atan2(d.x, -d.z) / (2 pi), v = acos(d.y) / pi (row 0 is up)."""
    m = env_map_direction(d, rotation)
    m = m / np.linalg.norm(m, axis=-1, keepdims=True)
    u = 0.5 + np.arctan2(m[..., 0], -m[..., 2]) / (2.0 * math.pi)
    v = np.arccos(np.clip(m[..., 1], -1.0, 1.0)) / math.pi
    return np.stack([u, v], axis=-1)


def sample_bilinear(env: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """GL's LINEAR lookup of map ``env`` (H, W, C) at ``uv`` (..., 2): texel centres at
    (i + 1/2) / size, u wrapping (REPEAT), v clamped to the edge rows (CLAMP_TO_EDGE)."""
    h, w = env.shape[:2]
    x = uv[..., 0] * w - 0.5
    y = np.clip(uv[..., 1] * h - 0.5, 0.0, h - 1.0)
    x0, y0 = np.floor(x), np.minimum(np.floor(y), h - 2 if h > 1 else 0)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    i0, i1 = x0.astype(int) % w, (x0.astype(int) + 1) % w
    j0 = y0.astype(int)
    j1 = np.minimum(j0 + 1, h - 1)
    e = np.asarray(env, np.float64)
    top = e[j0, i0] * (1 - fx) + e[j0, i1] * fx
    bottom = e[j1, i0] * (1 - fx) + e[j1, i1] * fx
    return top * (1 - fy) + bottom * fy


def texel_directions(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit direction of each texel centre (H, W, 3) and its solid angle (H, W) in sr.

    A row at polar angle theta spans d_omega = (cos theta0 - cos theta1) * 2 pi / W exactly
    (the band's area split evenly), so the solid angles sum to 4 pi to rounding."""
    edges = np.linspace(0.0, math.pi, height + 1)
    theta = 0.5 * (edges[:-1] + edges[1:])
    phi = (np.arange(width) + 0.5) / width * 2.0 * math.pi - math.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = np.stack(
        np.broadcast_arrays(st * np.sin(phi)[None, :], ct, -st * np.cos(phi)[None, :]), axis=-1
    )
    band = (np.cos(edges[:-1]) - np.cos(edges[1:])) * (2.0 * math.pi / width)
    return d, np.broadcast_to(band[:, None], (height, width)).copy()


def cube_direction(face: int, st: np.ndarray) -> np.ndarray:
    """The (unnormalised) direction of cube face ``face`` (0..5 = +X, -X, +Y, -Y, +Z, -Z)
    at texture coordinates st (..., 2) in [0, 1]: the inverse of the OpenGL spec's face
    selection (table 8.19)."""
    sc, tc = 2.0 * st[..., 0] - 1.0, 2.0 * st[..., 1] - 1.0
    one = np.ones_like(sc)
    return np.stack(
        [
            (one, -tc, -sc),
            (-one, -tc, sc),
            (sc, one, tc),
            (sc, -one, -tc),
            (sc, -tc, one),
            (-sc, -tc, -one),
        ][face],
        axis=-1,
    )
