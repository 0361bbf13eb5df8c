"""Twin of glsl/brdf/cloth.glsl: the empirical cloth terms of RTR4 §9.10.

Same names, same order of operations, float64, broadcasting; colours have a last axis
of 3. As in the GLSL the caller of ``f_cloth_empirical`` guarantees n.l > 0, clamps n.l to
[MIN_N_DOT_L, 1], n.v to [MIN_N_DOT_V, 1] and l.h to [0, 1]; the illumination sum takes
``f_cloth_empirical_past_terminator`` at n.l <= 1e-4 where w > 0. docs/cloth.md,
"Empirical", has the proofs.
"""

from __future__ import annotations

import numpy as np

from app.reference.constants import INV_PI
from app.reference.fresnel import pow5_one_minus

# At and below this n.l the wrapped light is f_cloth_empirical_past_terminator's (not divided
# by n.l); above it wrap_cloth_empirical divides by n.l.
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


def wrapped_cosine_cloth_empirical(rtr4: bool, w: float, NoL: np.ndarray) -> np.ndarray:
    """The wrapped cosine that replaces (n.l)+ (RTR4 §9.10), any n.l in [-1, 1]: the book's
    (and the curriculum's) clamp(n.l + w, 0, 1) / (1 + w) where ``rtr4``, else Filament's
    (its Fd_Wrap) (n.l + w)+ / (1 + w)^2.

    Over the sphere of l, Filament's integrates to π = ∫ (n.l)+ dl (it conserves energy);
    the book's to π (1 + 2w)/(1 + w) (a white furnace reflects (1 + 2w)/(1 + w))."""
    NoL = _f64(NoL)
    if rtr4:
        return np.clip(NoL + w, 0.0, 1.0) / (1.0 + w)
    return np.maximum(NoL + w, 0.0) / ((1.0 + w) * (1.0 + w))


def wrap_cloth_empirical(
    rtr4: bool, c_scatter: np.ndarray, w: float, NoL: np.ndarray
) -> np.ndarray:
    """The wrap on the lit side (n.l > CLOTH_WRAP_MIN_N_DOT_L) divided by n.l, (..., 3):
    W = clamp(c_scatter + n.l, 0, 1) cos_w(n.l) / n.l with n.l floored at 1e-4 in the
    division; Filament's (1 + w/n.l)/(1 + w)^2, the book's min(1 + w/n.l, 1/n.l)/(1 + w).

    At and below 1e-4 the illumination sum takes ``f_cloth_empirical_past_terminator``."""
    NoL = _f64(NoL)
    d = np.maximum(NoL, CLOTH_WRAP_MIN_N_DOT_L)
    if rtr4:
        k = np.minimum(1.0 + w / d, 1.0 / d) / (1.0 + w)
    else:
        k = (1.0 + w / d) / ((1.0 + w) * (1.0 + w))
    return np.clip(_f64(c_scatter) + NoL[..., None], 0.0, 1.0) * k[..., None]


def f_sheen_cloth_empirical(sheen: np.ndarray, LoH: np.ndarray) -> np.ndarray:
    """RTR4 §9.10's Schlick-like sheen k_sheen c_sheen (1 - (h.l)+)^5; ``sheen`` is the
    product k_sheen c_sheen. Reciprocal (h.l = h.v)."""
    return _f64(sheen) * pow5_one_minus(LoH)[..., None]


def f_cloth_empirical(
    rtr4: bool,
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
    return lobes * wrap_cloth_empirical(rtr4, c_scatter, w, NoL) + f_sheen_cloth_empirical(
        sheen, LoH
    )


def f_cloth_empirical_past_terminator(
    rtr4: bool,
    rho_ss: np.ndarray,
    rim_inner: np.ndarray,
    k_diff: float,
    c_scatter: np.ndarray,
    w: float,
    NoL: np.ndarray,
    NoV: np.ndarray,
) -> np.ndarray:
    """f (n.l) past the terminator (n.l <= 1e-4, down to -w), not divided by n.l:
    lobes(v) clamp(c_scatter + (n.l)+, 0, 1) cos_w(n.l); the sheen adds nothing there.
    Equal at n.l = 0 to the lit side's f (n.l) without the sheen."""
    lobes = Fd_cloth_empirical(rho_ss, rim_inner, k_diff, NoV)
    NoL = _f64(NoL)
    tint = np.clip(_f64(c_scatter) + np.maximum(NoL, 0.0)[..., None], 0.0, 1.0)
    return lobes * (tint * wrapped_cosine_cloth_empirical(rtr4, w, NoL)[..., None])
