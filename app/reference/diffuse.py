"""Twin of glsl/brdf/diffuse.glsl: diffuse (subsurface) terms."""

from __future__ import annotations

import numpy as np

from app.reference.constants import INV_PI


def Fd_lambert(rho_ss: np.ndarray) -> np.ndarray:
    """Lambert 1760; seed section 3: f = rho_ss/pi, directional albedo rho_ss."""
    return np.asarray(rho_ss, np.float64) * INV_PI
