"""A G-buffer read back to the CPU: what the lighting pass's twin shades and the tests read.

Layout and precision of the GPU targets are in docs/gbuffer.md (app/render/gbuffer.py owns
them); here every field is float32, rows top to bottom, with the meaning documented below
whatever the targets' storage (a unorm16 target's signed values are mapped back to [-1, 1]
on readback, as the decode does). ``ENCODINGS`` names the storages a scene's
``render.gbuffer`` chooses between.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Storage of the colour targets per ``render.gbuffer`` value (docs/gbuffer.md, "Encodings"):
# RT0 base colour + metallic, then the targets holding octahedral directions (RT1 normal +
# roughness + F0, RT3 tangent + anisotropy, RT4 coat normal). RT2 (view depth, material id)
# is RG32F in every encoding. ``f16``: RGBA16F, a float16 per channel; ``unorm16``: GL_RGBA16,
# a uniform grid of 65536 steps over [0, 1], the signed values (octahedral coordinates,
# anisotropy) mapped from [-1, 1] (Cigolle et al. 2014, "A Survey of Efficient
# Representations for Independent Unit Vectors": the octahedral map on a uniform grid);
# ``f32``: RGBA32F. The default is the one whose own error is a small part of the
# pipeline's budget, measured in docs/gbuffer.md: only f32 is.
ENCODINGS: dict[str, tuple[str, str]] = {
    "f16": ("f16", "f16"),
    "unorm16": ("unorm16", "unorm16"),
    "unorm16_base": ("unorm16", "f32"),  # base colour and metallic in unorm16, the rest f32
    "f32": ("f32", "f32"),
}
ENCODING_NAMES = tuple(ENCODINGS)
DEFAULT_ENCODING = "f32"
# Bytes of one texel's channel in each storage.
STORAGE_BYTES = {"f16": 2, "unorm16": 2, "f32": 4}


def encoding_defines(encoding: str) -> dict[str, int]:
    """The defines of every pass that writes or decodes a G-buffer of ``encoding``
    (gbuffer/layout.glsl): GBUFFER_UNORM_DIRECTIONS where the direction targets are unorm16
    (their signed values then pass through snorm_to_unorm / unorm_to_snorm). Nothing for
    float targets, so their programs compile exactly as before the encodings existed."""
    return {"GBUFFER_UNORM_DIRECTIONS": 1} if ENCODINGS[encoding][1] == "unorm16" else {}


def bytes_per_pixel(encoding: str, tangents: bool = False, coat_normals: bool = False) -> int:
    """The G-buffer's bytes per pixel: RT0 and RT1 (4 channels each), RT2 (RG32F), RT3 (4)
    and RT4 (2) where present; the DEPTH24 z-test buffer not counted."""
    base, directions = (STORAGE_BYTES[s] for s in ENCODINGS[encoding])
    channels = 4 + 4 * int(tangents) + 2 * int(coat_normals)
    return 4 * base + channels * directions + 8


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
    # (H, W, 4): emitted radiance (linear RGB), occlusion factor of environment light; None
    # where the G-buffer has no RT5 (nothing emits and no occlusion map: glTF 2.0 core)
    emission: np.ndarray | None = None

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: the pixels a surface was drawn into."""
        return np.isfinite(self.depth) & (self.depth > 0.0)
