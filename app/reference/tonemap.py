"""Twin of glsl/post/tonemap.glsl: exposure, tone mapping, sRGB encoding."""

from __future__ import annotations

import numpy as np


def tonemap_khronos_neutral(c: np.ndarray) -> np.ndarray:
    """Khronos PBR Neutral (2024)."""
    c = np.array(c, np.float64)
    start = 0.8 - 0.04
    desaturation = 0.15
    x = np.min(c, axis=-1, keepdims=True)
    offset = np.where(x < 0.08, x - 6.25 * x * x, 0.04)
    c = c - offset
    peak = np.max(c, axis=-1, keepdims=True)
    d = 1.0 - start
    new_peak = 1.0 - d * d / (peak + d - start)
    with np.errstate(divide="ignore", invalid="ignore"):
        scaled = c * (new_peak / peak)
    g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0)
    compressed = scaled * (1.0 - g) + new_peak * g
    return np.where(peak < start, c, compressed)


def tonemap_aces_narkowicz(x: np.ndarray) -> np.ndarray:
    """Narkowicz 2015, fit of the ACES RRT+ODT."""
    x = np.asarray(x, np.float64)
    return np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def tonemap_reinhard(x: np.ndarray) -> np.ndarray:
    """Reinhard et al. 2002: x/(1 + x)."""
    x = np.asarray(x, np.float64)
    return x / (1.0 + x)


def srgb_encode(c: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB transfer function (linear -> encoded), input clamped to [0, 1]."""
    c = np.clip(np.asarray(c, np.float64), 0.0, 1.0)
    return np.where(c < 0.0031308, 12.92 * c, 1.055 * c ** (1.0 / 2.4) - 0.055)


def srgb_decode(c: np.ndarray) -> np.ndarray:
    """Inverse of ``srgb_encode``."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


MAX_EXPOSED = 1.0e9  # as glsl/post/tonemap.glsl: keeps tone maps from overflowing float32


def post_process(hdr: np.ndarray, exposure_ev: float, tonemap: str) -> np.ndarray:
    """HDR radiance -> display-encoded values in [0, 1], as glsl/passes/post.frag."""
    c = np.minimum(np.asarray(hdr, np.float64)[..., :3] * 2.0**exposure_ev, MAX_EXPOSED)
    if tonemap == "neutral":
        c = tonemap_khronos_neutral(c)
    elif tonemap == "aces":
        c = tonemap_aces_narkowicz(c)
    elif tonemap == "reinhard":
        c = tonemap_reinhard(c)
    return srgb_encode(c)
