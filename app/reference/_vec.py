"""Small vector helpers for the float64 twins (last axis = xyz)."""

from __future__ import annotations

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the last axis."""
    return np.sum(np.asarray(a, np.float64) * np.asarray(b, np.float64), axis=-1)


def normalize(a: np.ndarray) -> np.ndarray:
    """Unit vector along ``a`` (last axis)."""
    a = np.asarray(a, np.float64)
    return a / np.linalg.norm(a, axis=-1, keepdims=True)
