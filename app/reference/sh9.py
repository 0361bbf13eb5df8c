"""The environment map as texels and its nine spherical-harmonic coefficients, in float64
(docs/ibl.md): the part of the IBL twin a render itself runs (the irradiance's SH9 in
app/render/ibl.py, the environment's cell integrals in app/frame/lights.py), in a module
of its own so that a render imports numpy alone for them, not app/reference/ibl.py's BRDF
twins (docs/performance.md, "A real asset against f3d"); app/reference/ibl.py names them
too."""

from __future__ import annotations

import numpy as np

from app.reference.environment import rotate_y, texel_directions

# --- the map as texels ---------------------------------------------------------------------


def map_texels(env: np.ndarray, rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """World directions (T, 3) of the map's texels (turned ``rotation`` radians about +Y)
    and their radiance times solid angle, L dOmega (T, 3)."""
    d, omega = texel_directions(*env.shape[:2])
    d = rotate_y(d, rotation).reshape(-1, 3)
    return d, np.asarray(env, np.float64).reshape(-1, 3) * omega.reshape(-1, 1)


# --- spherical harmonics (Ramamoorthi & Hanrahan 2001) -----------------------------------

# Their eq. 3 normalisation constants and eq. 13 irradiance constants.
SH_Y = (0.282095, 0.488603, 1.092548, 0.315392, 0.546274)
SH_C = (0.429043, 0.511664, 0.743125, 0.886227, 0.247708)


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """The 9 real SH basis functions at unit directions d (..., 3) -> (..., 9), ordered
    L00, L1-1 (y), L10 (z), L11 (x), L2-2 (xy), L2-1 (yz), L20, L21 (xz), L22."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    y0, y1, y2, y3, y4 = SH_Y
    return np.stack(
        [np.full_like(x, y0), y1 * y, y1 * z, y1 * x, y2 * x * y, y2 * y * z,
         y3 * (3.0 * z * z - 1.0), y2 * x * z, y4 * (x * x - y * y)],
        axis=-1,
    )  # fmt: skip


def sh9_project(env: np.ndarray, rotation: float) -> np.ndarray:
    """L_lm = sum over texels L Y_lm dOmega: (9, 3)."""
    d, l_domega = map_texels(env, rotation)
    return sh9_basis(d).T @ l_domega


def sh9_irradiance(L: np.ndarray, n: np.ndarray) -> np.ndarray:
    """E(n) from the 9 coefficients L (9, 3) (Ramamoorthi & Hanrahan 2001, eq. 13), for
    unit normals n (..., 3) -> (..., 3)."""
    c1, c2, c3, c4, c5 = SH_C
    x, y, z = (np.asarray(n, np.float64)[..., i, None] for i in range(3))
    return (
        c1 * L[8] * (x * x - y * y) + c3 * L[6] * z * z + c4 * L[0] - c5 * L[6]
        + 2.0 * c1 * (L[4] * x * y + L[7] * x * z + L[5] * y * z)
        + 2.0 * c2 * (L[3] * x + L[1] * y + L[2] * z)
    )  # fmt: skip
