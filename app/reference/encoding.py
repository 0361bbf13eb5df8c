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


def snorm_to_unorm(x: np.ndarray) -> np.ndarray:
    """[-1, 1] -> [0, 1]: a signed G-buffer value (octahedral coordinate, anisotropy) as a
    16-bit unorm target stores it. The code k = round(u * 65535) decodes to
    (k - 32767) / 32767: snorm16's uniform grid (step 1/32767, code 65535 unused), on
    which -1, 0 and 1 are exact, so axis-aligned normals and anisotropy 0 store exactly
    (Cigolle et al. 2014 quantise the octahedral square on such a grid)."""
    return (np.asarray(x, np.float64) * 32767.0 + 32767.0) / 65535.0


def unorm_to_snorm(u: np.ndarray) -> np.ndarray:
    """[0, 1] -> [-1, 1]: the inverse of snorm_to_unorm, as the decode applies it."""
    return (np.asarray(u, np.float64) * 65535.0 - 32767.0) / 32767.0


def finite_or(x: np.ndarray, fallback: float) -> np.ndarray:
    """x, or ``fallback`` where x is NaN or +-Inf: the value a unorm target is given
    where a float target would carry NaN to the decode's sanitize_value."""
    x = np.asarray(x, np.float64)
    return np.where(np.isfinite(x), x, fallback)
