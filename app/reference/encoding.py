"""Twin of glsl/common/encoding.glsl: octahedral unit-vector encoding.

Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit Vectors".
"""

from __future__ import annotations

import numpy as np

from app.reference._vec import normalize


def sign_not_zero(v: np.ndarray) -> np.ndarray:
    """+1 for v >= 0, -1 otherwise (sign() would map 0 to 0)."""
    return np.where(v >= 0.0, 1.0, -1.0)


def oct_encode(n: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) -> points in [-1, 1]^2 (..., 2)."""
    n = np.asarray(n, np.float64)
    p = n[..., :2] / np.sum(np.abs(n), axis=-1, keepdims=True)
    folded = (1.0 - np.abs(p[..., ::-1])) * sign_not_zero(p)
    return np.where(n[..., 2:3] >= 0.0, p, folded)


def oct_decode(e: np.ndarray) -> np.ndarray:
    """Points in [-1, 1]^2 (..., 2) -> unit vectors (..., 3)."""
    e = np.asarray(e, np.float64)
    z = 1.0 - np.abs(e[..., 0]) - np.abs(e[..., 1])
    xy = np.where(z[..., None] < 0.0, (1.0 - np.abs(e[..., ::-1])) * sign_not_zero(e), e)
    return normalize(np.concatenate([xy, z[..., None]], axis=-1))
