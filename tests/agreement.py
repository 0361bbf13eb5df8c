"""How GLSL results are compared with their float64 twins."""

from __future__ import annotations

import numpy as np


def relative_error(gpu: np.ndarray, ref: np.ndarray, floor: float) -> np.ndarray:
    """|gpu - ref| / max(|ref|, floor): relative where the reference is not tiny.

    ``floor`` is the magnitude below which a value counts as zero, so values that are
    exactly 0 in float64 are compared absolutely instead of dividing by 0.
    """
    gpu = np.asarray(gpu, np.float64)
    ref = np.asarray(ref, np.float64)
    return np.abs(gpu - ref) / np.maximum(np.abs(ref), floor)
