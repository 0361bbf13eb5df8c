"""Float64 twin of render.antialiasing = "msaa" (app/render/msaa.py, docs/antialiasing.md):
which pixels glsl/passes/msaa.frag marks, the background a sample without a surface takes
(glsl/passes/msaa_background.glsl), and the value the lighting pass's per-sample programs
(glsl/passes/lighting.frag under GBUFFER_SAMPLES) leave there.

Arrays are indexed ``[y, x]`` in GL's order (row 0 at the bottom), as the read-back
targets are: the one-sample G-buffer's RT2 as ``centre`` (H, W, 2: view depth, material
id), the multisampled G-buffer's RT2 and octahedral normals (RT1's first two channels)
per sample as ``samples`` (S, H, W, 2) and ``normals`` (S, H, W, 2).
"""

from __future__ import annotations

import numpy as np

# app/render/msaa.py's tolerances (msaa.frag's u_depth_tolerance, u_normal_tolerance)
MSAA_DEPTH_TOLERANCE = 0.01
MSAA_NORMAL_TOLERANCE = 0.02
# msaa_background.glsl's steps, in its order: the pixel itself, then +x, -x, +y, -y
MSAA_BACKGROUND_STEPS = ((0, 0), (1, 0), (-1, 0), (0, 1), (0, -1))


def _covered(z: np.ndarray) -> np.ndarray:
    return np.isfinite(z) & (z > 0.0)


def msaa_same_surface(a: np.ndarray, b: np.ndarray, tolerance: float) -> np.ndarray:
    """Whether RT2 texels ``a`` and ``b`` (..., 2) hold one surface (msaa.frag's
    ``same_surface``): both the background, or the same material id at view depths within
    ``tolerance`` of the nearer one's."""
    ca, cb = _covered(a[..., 0]), _covered(b[..., 0])
    near = np.abs(a[..., 0] - b[..., 0]) <= tolerance * np.minimum(a[..., 0], b[..., 0])
    surfaces = ca & cb & (a[..., 1] == b[..., 1]) & near
    return np.where(ca & cb, surfaces, ~ca & ~cb)


def msaa_edges(
    centre: np.ndarray,
    samples: np.ndarray,
    normals: np.ndarray,
    depth_tolerance: float = MSAA_DEPTH_TOLERANCE,
    normal_tolerance: float = MSAA_NORMAL_TOLERANCE,
) -> np.ndarray:
    """(H, W) bool: the pixels msaa.frag marks. A pixel is an edge where its centre or a
    sample s > 0 holds another surface than sample 0, or where sample 0 holds a surface and
    a sample's octahedral normal differs from sample 0's by more than ``normal_tolerance``
    in a coordinate."""
    g0, n0 = samples[0], normals[0]
    edge = ~msaa_same_surface(g0, centre, depth_tolerance)
    for gs, ns in zip(samples[1:], normals[1:], strict=True):
        turned = np.any(np.abs(ns - n0) > normal_tolerance, axis=-1)
        edge |= ~msaa_same_surface(g0, gs, depth_tolerance) | (_covered(g0[..., 0]) & turned)
    return edge


def msaa_background(hdr: np.ndarray, centre: np.ndarray, background: np.ndarray) -> np.ndarray:
    """(H, W, 4): the radiance msaa_background.glsl gives a sample of each pixel that sees
    no surface: ``hdr`` (the frame shaded at the pixel centres, linear RGBA) at the first
    of ``MSAA_BACKGROUND_STEPS`` (the pixel, then its 4 neighbours, each index clamped to
    the image as the shader's ``clamp`` does) whose ``centre`` (RT2, H, W, 2) holds no
    surface, else ``background`` (the uniform background's RGBA, 4)."""
    h, w = centre.shape[:2]
    out = np.empty((h, w, 4))
    out[...] = np.asarray(background, np.float64)
    found = np.zeros((h, w), bool)
    for dx, dy in MSAA_BACKGROUND_STEPS:
        ys = np.clip(np.arange(h) + dy, 0, h - 1)[:, None]
        xs = np.clip(np.arange(w) + dx, 0, w - 1)[None, :]
        take = ~found & ~_covered(centre[ys, xs, 0])
        out[take] = hdr[ys, xs][take]
        found |= take
    return out


def msaa_resolve(hdr: np.ndarray, edges: np.ndarray, sample_radiance: np.ndarray) -> np.ndarray:
    """(H, W, 4): ``hdr`` (the frame shaded at the pixel centres, linear RGBA) with each
    pixel of ``edges`` the mean of ``sample_radiance`` (S, H, W, 4: each sample's RGBA, its
    surface's radiance with alpha 1 or the background behind it), a box over the pixel."""
    return np.where(edges[..., None], sample_radiance.mean(axis=0), hdr)
