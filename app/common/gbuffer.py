"""A G-buffer read back to the CPU: what the lighting pass's twin shades and the tests read.

Layout and precision of the GPU targets are in docs/gbuffer.md (app/render/gbuffer.py owns
them); here every field is float32, rows top to bottom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class GBufferData:
    """The G-buffer of one frame, (H, W) per pixel."""

    base_color: np.ndarray  # (H, W, 4): linear base colour (F0 for metals), metallic
    normal: np.ndarray  # (H, W, 4): octahedral normal (x, y), perceptual roughness, F0
    depth: np.ndarray  # (H, W): view depth in metres, 0 = background
    # (H, W, 4): octahedral tangent (x, y), anisotropy, 0; zeros where the G-buffer has no
    # tangent target (no anisotropic material in the frame)
    tangent: np.ndarray
    material_id: np.ndarray  # (H, W): the row of the material table (an exact integer)
    # (H, W, 2): octahedral clear-coat normal (x, y); None where the G-buffer has no coat
    # normal target (no coat's normal differs from its base's: the coat shades with the
    # normal above)
    coat_normal: np.ndarray | None = None

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: the pixels a surface was drawn into."""
        return np.isfinite(self.depth) & (self.depth > 0.0)
