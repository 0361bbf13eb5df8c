"""Twin of glsl/material/normal_mapping.glsl: tangent-space normal mapping, in float64.

OpenGL convention: +x along +u, +y along +v, +z along the surface normal. Every function
broadcasts over the leading axes (last axis = xyz).
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import dot

MIN_TANGENT = 1e-6  # below this length of the orthogonalised tangent the frame is undefined


def tangent_space_normal(texel: np.ndarray) -> np.ndarray:
    """The unit tangent-space normal a filtered normal-map texel stands for: the texel
    renormalised (filtering shortens averaged unit normals), +z where it has length 0."""
    texel = np.asarray(texel, np.float64)
    length = np.linalg.norm(texel, axis=-1, keepdims=True)
    up = np.broadcast_to([0.0, 0.0, 1.0], texel.shape)
    return np.where(length > 0.0, texel / np.where(length > 0.0, length, 1.0), up)


def tangent_frame(
    ng: np.ndarray, t: np.ndarray, w: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t', b, ok): Mikkelsen 2008's frame, t' = t - ng (ng.t) renormalised and
    b = sign(w) cross(ng, t') (w = 0 counts as +1); ok is False (keepdims) where
    |t'| <= 1e-6, the frame undefined there."""
    ng = np.asarray(ng, np.float64)
    t = np.asarray(t, np.float64)
    tt = t - ng * dot(ng, t)[..., None]
    length = np.linalg.norm(tt, axis=-1, keepdims=True)
    ok = length > MIN_TANGENT
    tt = tt / np.where(ok, length, 1.0)
    sign = np.where(np.asarray(w, np.float64) < 0.0, -1.0, 1.0)[..., None]
    return tt, np.cross(ng, tt) * sign, ok


def perturb_normal(ng: np.ndarray, t: np.ndarray, w: np.ndarray, n_ts: np.ndarray) -> np.ndarray:
    """Mikkelsen 2008 (MikkTSpace, glTF): the frame t' = t - ng (ng.t) renormalised,
    b = sign(w) cross(ng, t') (w = 0 counts as +1), and the mapped normal
    normalize(t' n_ts.x + b n_ts.y + ng n_ts.z); ng itself where |t'| <= 1e-6."""
    ng = np.asarray(ng, np.float64)
    n_ts = np.asarray(n_ts, np.float64)
    tt, b, ok = tangent_frame(ng, t, w)
    n = tt * n_ts[..., :1] + b * n_ts[..., 1:2] + ng * n_ts[..., 2:3]
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    return np.where(ok, n, ng)


def rotate_tangent(
    ng: np.ndarray, t: np.ndarray, w: np.ndarray, direction: np.ndarray
) -> np.ndarray:
    """glTF KHR_materials_anisotropy's direction in the tangent plane (RTR4 §9.8): with the
    frame t' = t - ng (ng.t) renormalised and b = sign(w) cross(ng, t') of ``perturb_normal``,
    the unit tangent normalize(t' d.x + b d.y) for the 2D direction d; t itself where
    |t'| <= 1e-6 (the frame is undefined)."""
    t = np.asarray(t, np.float64)
    d = np.asarray(direction, np.float64)
    tt, b, ok = tangent_frame(ng, t, w)
    r = tt * d[..., :1] + b * d[..., 1:2]
    r = r / np.linalg.norm(r, axis=-1, keepdims=True)
    return np.where(ok, r, t)


def anisotropy_direction(texel: np.ndarray) -> np.ndarray:
    """The unit 2D direction a filtered direction-map texel (the decoded 2 rg - 1) stands
    for: renormalised; (1, 0), the tangent itself, where it has length 0."""
    texel = np.asarray(texel, np.float64)
    length = np.linalg.norm(texel, axis=-1, keepdims=True)
    along = np.broadcast_to([1.0, 0.0], texel.shape)
    return np.where(length > 0.0, texel / np.where(length > 0.0, length, 1.0), along)
