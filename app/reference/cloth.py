"""Twin of glsl/brdf/cloth.glsl: the empirical cloth terms of RTR4 §9.10.

Same names, same order of operations, float64, broadcasting; colours have a last axis
of 3. As in the GLSL the caller guarantees n.l > 0, clamps n.l to [MIN_N_DOT_L, 1], n.v to
[MIN_N_DOT_V, 1] and l.h to [0, 1]. docs/cloth.md, "Empirical", has the proofs.
"""

from __future__ import annotations

import numpy as np

from app.reference.constants import INV_PI
from app.reference.fresnel import pow5_one_minus

# Below this n.l the wrap factor divides by it instead of n.l (see wrap_cloth_empirical).
CLOTH_WRAP_MIN_N_DOT_L = 1e-4


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def Fd_cloth_empirical(
    rho_ss: np.ndarray, rim_inner: np.ndarray, k_diff: float, NoV: np.ndarray
) -> np.ndarray:
    """Hable 2010, "Uncharted 2: Character Lighting and Shading", as RTR4 §9.10 gives it:
    f = rho_ss/pi (k_rim (n.v)^a_rim + k_inner (1 - n.v)^a_inner + k_diff).

    ``rim_inner`` = (k_rim, a_rim, k_inner, a_inner). Not reciprocal: the rim and inner
    lobes depend on v only."""
    k_rim, a_rim, k_inner, a_inner = (float(x) for x in rim_inner)
    NoV = _f64(NoV)
    rim = k_rim * NoV**a_rim
    inner = k_inner * (1.0 - NoV) ** a_inner
    return _f64(rho_ss) * (INV_PI * (rim + inner + k_diff))[..., None]


def wrap_cloth_empirical(c_scatter: np.ndarray, w: float, NoL: np.ndarray) -> np.ndarray:
    """Energy-conserving wrap lighting with a scatter colour (RTR4 §9.10), divided by n.l:
    f_diff (n.l)+ => f_diff clamp(c_scatter + n.l, 0, 1) (n.l + w)+ / (1 + w)^2, so
    W = clamp(c_scatter + n.l, 0, 1) (1 + w / max(n.l, 1e-4)) / (1 + w)^2, (..., 3).

    ∫ (n.l + w)+ / (1 + w)^2 dl over the sphere is π, as ∫ (n.l)+ dl; the light behind the
    surface (-w < n.l <= 0) is not added by the illumination sum (docs/cloth.md)."""
    NoL = _f64(NoL)
    k = (1.0 + w / np.maximum(NoL, CLOTH_WRAP_MIN_N_DOT_L)) / ((1.0 + w) * (1.0 + w))
    return np.clip(_f64(c_scatter) + NoL[..., None], 0.0, 1.0) * k[..., None]


def f_sheen_cloth_empirical(sheen: np.ndarray, LoH: np.ndarray) -> np.ndarray:
    """RTR4 §9.10's Schlick-like sheen k_sheen c_sheen (1 - (h.l)+)^5; ``sheen`` is the
    product k_sheen c_sheen. Reciprocal (h.l = h.v)."""
    return _f64(sheen) * pow5_one_minus(LoH)[..., None]


def f_cloth_empirical(
    rho_ss: np.ndarray,
    rim_inner: np.ndarray,
    k_diff: float,
    c_scatter: np.ndarray,
    w: float,
    sheen: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    LoH: np.ndarray,
) -> np.ndarray:
    """The whole empirical cloth diffuse model: the lobes through the wrap, plus the sheen."""
    lobes = Fd_cloth_empirical(rho_ss, rim_inner, k_diff, NoV)
    return lobes * wrap_cloth_empirical(c_scatter, w, NoL) + f_sheen_cloth_empirical(sheen, LoH)
