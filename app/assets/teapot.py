"""The Utah teapot, tessellated from its bicubic Bézier patches and written as an OBJ.

Why generate it rather than check in a downloaded mesh: the patch table is the
canonical definition, it is small enough to read, and tessellating it here gives
analytic normals (from the patch derivatives, not from averaged face normals) and
a mesh whose resolution is a parameter.

Source: Martin Newell, 1975, the Utah teapot (University of Utah); the 32 patches
and 306 control points as published by Frank Crow, "The Origins of the Teapot",
IEEE Computer Graphics and Applications 7(1), 1987.

The data is Z-up with the bottom at z = 0 and the knob apex at z = 3.15. The mesh
this module produces is Y-up (``y = z_old``, ``z = -y_old``, a proper rotation, so
winding and normals survive) and scaled by exactly ``1 / 3.15``, so it stands on
``y = 0`` and is exactly 1 unit tall. The body's axis of revolution (the lid axis)
stays at ``x = z = 0``; the bounding box is not centred in x because the spout
reaches further (x ≈ +1.09) than the handle (x ≈ -0.95).

Run ``python -m app.assets.teapot`` (or this file) to rewrite
``scenes/meshes/teapot.obj``; ``tests/test_teapot.py`` checks the checked-in file
still matches a fresh build.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = [
    "PATCHES",
    "SCALE",
    "SEGMENTS",
    "VERTICES",
    "build_teapot",
    "default_obj_path",
    "main",
    "write_obj",
]

#: Default tessellation: each patch is sampled on a (SEGMENTS + 1)² parameter grid.
SEGMENTS = 12

#: Uniform scale from the data's units to the output mesh: data height 3.15 → 1.
SCALE = 1.0 / 3.15

# Control-point indices of the 32 bicubic patches, 1-based as published. Each row
# is a 4×4 patch in row-major order (u selects the row of four, v the column).
# Patches 1-4: rim, 5-12: body, 13-16: handle, 17-20: spout, 21-24: lid knob,
# 25-28: lid, 29-32: bottom.
PATCHES: tuple[tuple[int, ...], ...] = (
    # rim
    (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16),
    (4, 17, 18, 19, 8, 20, 21, 22, 12, 23, 24, 25, 16, 26, 27, 28),
    (19, 29, 30, 31, 22, 32, 33, 34, 25, 35, 36, 37, 28, 38, 39, 40),
    (31, 41, 42, 1, 34, 43, 44, 5, 37, 45, 46, 9, 40, 47, 48, 13),
    # body, upper
    (13, 14, 15, 16, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60),
    (16, 26, 27, 28, 52, 61, 62, 63, 56, 64, 65, 66, 60, 67, 68, 69),
    (28, 38, 39, 40, 63, 70, 71, 72, 66, 73, 74, 75, 69, 76, 77, 78),
    (40, 47, 48, 13, 72, 79, 80, 49, 75, 81, 82, 53, 78, 83, 84, 57),
    # body, lower
    (57, 58, 59, 60, 85, 86, 87, 88, 89, 90, 91, 92, 93, 94, 95, 96),
    (60, 67, 68, 69, 88, 97, 98, 99, 92, 100, 101, 102, 96, 103, 104, 105),
    (69, 76, 77, 78, 99, 106, 107, 108, 102, 109, 110, 111, 105, 112, 113, 114),
    (78, 83, 84, 57, 108, 115, 116, 85, 111, 117, 118, 89, 114, 119, 120, 93),
    # handle
    (121, 122, 123, 124, 125, 126, 127, 128, 129, 130, 131, 132, 133, 134, 135, 136),
    (124, 137, 138, 121, 128, 139, 140, 125, 132, 141, 142, 129, 136, 143, 144, 133),
    (133, 134, 135, 136, 145, 146, 147, 148, 149, 150, 151, 152, 69, 153, 154, 155),
    (136, 143, 144, 133, 148, 156, 157, 145, 152, 158, 159, 149, 155, 160, 161, 69),
    # spout
    (162, 163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177),
    (165, 178, 179, 162, 169, 180, 181, 166, 173, 182, 183, 170, 177, 184, 185, 174),
    (174, 175, 176, 177, 186, 187, 188, 189, 190, 191, 192, 193, 194, 195, 196, 197),
    (177, 184, 185, 174, 189, 198, 199, 186, 193, 200, 201, 190, 197, 202, 203, 194),
    # lid knob (first row collapsed to the apex: a pole)
    (204, 204, 204, 204, 207, 208, 209, 210, 211, 211, 211, 211, 212, 213, 214, 215),
    (204, 204, 204, 204, 210, 217, 218, 219, 211, 211, 211, 211, 215, 220, 221, 222),
    (204, 204, 204, 204, 219, 224, 225, 226, 211, 211, 211, 211, 222, 227, 228, 229),
    (204, 204, 204, 204, 226, 230, 231, 207, 211, 211, 211, 211, 229, 232, 233, 212),
    # lid
    (212, 213, 214, 215, 234, 235, 236, 237, 238, 239, 240, 241, 242, 243, 244, 245),
    (215, 220, 221, 222, 237, 246, 247, 248, 241, 249, 250, 251, 245, 252, 253, 254),
    (222, 227, 228, 229, 248, 255, 256, 257, 251, 258, 259, 260, 254, 261, 262, 263),
    (229, 232, 233, 212, 257, 264, 265, 234, 260, 266, 267, 238, 263, 268, 269, 242),
    # bottom (first row collapsed to the centre: a pole)
    (270, 270, 270, 270, 279, 280, 281, 282, 275, 276, 277, 278, 271, 272, 273, 274),
    (270, 270, 270, 270, 282, 289, 290, 291, 278, 286, 287, 288, 274, 283, 284, 285),
    (270, 270, 270, 270, 291, 298, 299, 300, 288, 295, 296, 297, 285, 292, 293, 294),
    (270, 270, 270, 270, 300, 305, 306, 279, 297, 303, 304, 275, 294, 301, 302, 271),
)

# Which part each patch belongs to. Seams are welded only within a part: the
# handle's lower end touches a body vertex at (-2, 0, 0.9) exactly, and welding
# across parts there would average a handle normal into the body's shading.
_PART_OF_PATCH: tuple[int, ...] = (0,) * 12 + (1,) * 4 + (2,) * 4 + (3,) * 8 + (0,) * 4

# The 306 control points (x, y, z), Z-up. Points 205, 206, 216 and 223 are in the
# published table but no patch uses them.
# fmt: off
VERTICES: tuple[tuple[float, float, float], ...] = (
    (1.4, 0.0, 2.4), (1.4, -0.784, 2.4), (0.784, -1.4, 2.4), (0.0, -1.4, 2.4),
    (1.3375, 0.0, 2.53125), (1.3375, -0.749, 2.53125), (0.749, -1.3375, 2.53125),
    (0.0, -1.3375, 2.53125), (1.4375, 0.0, 2.53125), (1.4375, -0.805, 2.53125),
    (0.805, -1.4375, 2.53125), (0.0, -1.4375, 2.53125), (1.5, 0.0, 2.4),
    (1.5, -0.84, 2.4), (0.84, -1.5, 2.4), (0.0, -1.5, 2.4), (-0.784, -1.4, 2.4),
    (-1.4, -0.784, 2.4), (-1.4, 0.0, 2.4), (-0.749, -1.3375, 2.53125),
    (-1.3375, -0.749, 2.53125), (-1.3375, 0.0, 2.53125), (-0.805, -1.4375, 2.53125),
    (-1.4375, -0.805, 2.53125), (-1.4375, 0.0, 2.53125), (-0.84, -1.5, 2.4),
    (-1.5, -0.84, 2.4), (-1.5, 0.0, 2.4), (-1.4, 0.784, 2.4), (-0.784, 1.4, 2.4),
    (0.0, 1.4, 2.4), (-1.3375, 0.749, 2.53125), (-0.749, 1.3375, 2.53125),
    (0.0, 1.3375, 2.53125), (-1.4375, 0.805, 2.53125), (-0.805, 1.4375, 2.53125),
    (0.0, 1.4375, 2.53125), (-1.5, 0.84, 2.4), (-0.84, 1.5, 2.4), (0.0, 1.5, 2.4),
    (0.784, 1.4, 2.4), (1.4, 0.784, 2.4), (0.749, 1.3375, 2.53125),
    (1.3375, 0.749, 2.53125), (0.805, 1.4375, 2.53125), (1.4375, 0.805, 2.53125),
    (0.84, 1.5, 2.4), (1.5, 0.84, 2.4), (1.75, 0.0, 1.875), (1.75, -0.98, 1.875),
    (0.98, -1.75, 1.875), (0.0, -1.75, 1.875), (2.0, 0.0, 1.35), (2.0, -1.12, 1.35),
    (1.12, -2.0, 1.35), (0.0, -2.0, 1.35), (2.0, 0.0, 0.9), (2.0, -1.12, 0.9),
    (1.12, -2.0, 0.9), (0.0, -2.0, 0.9), (-0.98, -1.75, 1.875), (-1.75, -0.98, 1.875),
    (-1.75, 0.0, 1.875), (-1.12, -2.0, 1.35), (-2.0, -1.12, 1.35), (-2.0, 0.0, 1.35),
    (-1.12, -2.0, 0.9), (-2.0, -1.12, 0.9), (-2.0, 0.0, 0.9), (-1.75, 0.98, 1.875),
    (-0.98, 1.75, 1.875), (0.0, 1.75, 1.875), (-2.0, 1.12, 1.35), (-1.12, 2.0, 1.35),
    (0.0, 2.0, 1.35), (-2.0, 1.12, 0.9), (-1.12, 2.0, 0.9), (0.0, 2.0, 0.9),
    (0.98, 1.75, 1.875), (1.75, 0.98, 1.875), (1.12, 2.0, 1.35), (2.0, 1.12, 1.35),
    (1.12, 2.0, 0.9), (2.0, 1.12, 0.9), (2.0, 0.0, 0.45), (2.0, -1.12, 0.45),
    (1.12, -2.0, 0.45), (0.0, -2.0, 0.45), (1.5, 0.0, 0.225), (1.5, -0.84, 0.225),
    (0.84, -1.5, 0.225), (0.0, -1.5, 0.225), (1.5, 0.0, 0.15), (1.5, -0.84, 0.15),
    (0.84, -1.5, 0.15), (0.0, -1.5, 0.15), (-1.12, -2.0, 0.45), (-2.0, -1.12, 0.45),
    (-2.0, 0.0, 0.45), (-0.84, -1.5, 0.225), (-1.5, -0.84, 0.225), (-1.5, 0.0, 0.225),
    (-0.84, -1.5, 0.15), (-1.5, -0.84, 0.15), (-1.5, 0.0, 0.15), (-2.0, 1.12, 0.45),
    (-1.12, 2.0, 0.45), (0.0, 2.0, 0.45), (-1.5, 0.84, 0.225), (-0.84, 1.5, 0.225),
    (0.0, 1.5, 0.225), (-1.5, 0.84, 0.15), (-0.84, 1.5, 0.15), (0.0, 1.5, 0.15),
    (1.12, 2.0, 0.45), (2.0, 1.12, 0.45), (0.84, 1.5, 0.225), (1.5, 0.84, 0.225),
    (0.84, 1.5, 0.15), (1.5, 0.84, 0.15), (-1.6, 0.0, 2.025), (-1.6, -0.3, 2.025),
    (-1.5, -0.3, 2.25), (-1.5, 0.0, 2.25), (-2.3, 0.0, 2.025), (-2.3, -0.3, 2.025),
    (-2.5, -0.3, 2.25), (-2.5, 0.0, 2.25), (-2.7, 0.0, 2.025), (-2.7, -0.3, 2.025),
    (-3.0, -0.3, 2.25), (-3.0, 0.0, 2.25), (-2.7, 0.0, 1.8), (-2.7, -0.3, 1.8),
    (-3.0, -0.3, 1.8), (-3.0, 0.0, 1.8), (-1.5, 0.3, 2.25), (-1.6, 0.3, 2.025),
    (-2.5, 0.3, 2.25), (-2.3, 0.3, 2.025), (-3.0, 0.3, 2.25), (-2.7, 0.3, 2.025),
    (-3.0, 0.3, 1.8), (-2.7, 0.3, 1.8), (-2.7, 0.0, 1.575), (-2.7, -0.3, 1.575),
    (-3.0, -0.3, 1.35), (-3.0, 0.0, 1.35), (-2.5, 0.0, 1.125), (-2.5, -0.3, 1.125),
    (-2.65, -0.3, 0.9375), (-2.65, 0.0, 0.9375), (-2.0, -0.3, 0.9), (-1.9, -0.3, 0.6),
    (-1.9, 0.0, 0.6), (-3.0, 0.3, 1.35), (-2.7, 0.3, 1.575), (-2.65, 0.3, 0.9375),
    (-2.5, 0.3, 1.125), (-1.9, 0.3, 0.6), (-2.0, 0.3, 0.9), (1.7, 0.0, 1.425),
    (1.7, -0.66, 1.425), (1.7, -0.66, 0.6), (1.7, 0.0, 0.6), (2.6, 0.0, 1.425),
    (2.6, -0.66, 1.425), (3.1, -0.66, 0.825), (3.1, 0.0, 0.825), (2.3, 0.0, 2.1),
    (2.3, -0.25, 2.1), (2.4, -0.25, 2.025), (2.4, 0.0, 2.025), (2.7, 0.0, 2.4),
    (2.7, -0.25, 2.4), (3.3, -0.25, 2.4), (3.3, 0.0, 2.4), (1.7, 0.66, 0.6),
    (1.7, 0.66, 1.425), (3.1, 0.66, 0.825), (2.6, 0.66, 1.425), (2.4, 0.25, 2.025),
    (2.3, 0.25, 2.1), (3.3, 0.25, 2.4), (2.7, 0.25, 2.4), (2.8, 0.0, 2.475),
    (2.8, -0.25, 2.475), (3.525, -0.25, 2.49375), (3.525, 0.0, 2.49375),
    (2.9, 0.0, 2.475), (2.9, -0.15, 2.475), (3.45, -0.15, 2.5125), (3.45, 0.0, 2.5125),
    (2.8, 0.0, 2.4), (2.8, -0.15, 2.4), (3.2, -0.15, 2.4), (3.2, 0.0, 2.4),
    (3.525, 0.25, 2.49375), (2.8, 0.25, 2.475), (3.45, 0.15, 2.5125),
    (2.9, 0.15, 2.475), (3.2, 0.15, 2.4), (2.8, 0.15, 2.4), (0.0, 0.0, 3.15),
    (0.0, -0.002, 3.15), (0.002, 0.0, 3.15), (0.8, 0.0, 3.15), (0.8, -0.45, 3.15),
    (0.45, -0.8, 3.15), (0.0, -0.8, 3.15), (0.0, 0.0, 2.85), (0.2, 0.0, 2.7),
    (0.2, -0.112, 2.7), (0.112, -0.2, 2.7), (0.0, -0.2, 2.7), (0.002, 0.0, 3.15),
    (-0.45, -0.8, 3.15), (-0.8, -0.45, 3.15), (-0.8, 0.0, 3.15), (-0.112, -0.2, 2.7),
    (-0.2, -0.112, 2.7), (-0.2, 0.0, 2.7), (0.0, 0.002, 3.15), (-0.8, 0.45, 3.15),
    (-0.45, 0.8, 3.15), (0.0, 0.8, 3.15), (-0.2, 0.112, 2.7), (-0.112, 0.2, 2.7),
    (0.0, 0.2, 2.7), (0.45, 0.8, 3.15), (0.8, 0.45, 3.15), (0.112, 0.2, 2.7),
    (0.2, 0.112, 2.7), (0.4, 0.0, 2.55), (0.4, -0.224, 2.55), (0.224, -0.4, 2.55),
    (0.0, -0.4, 2.55), (1.3, 0.0, 2.55), (1.3, -0.728, 2.55), (0.728, -1.3, 2.55),
    (0.0, -1.3, 2.55), (1.3, 0.0, 2.4), (1.3, -0.728, 2.4), (0.728, -1.3, 2.4),
    (0.0, -1.3, 2.4), (-0.224, -0.4, 2.55), (-0.4, -0.224, 2.55), (-0.4, 0.0, 2.55),
    (-0.728, -1.3, 2.55), (-1.3, -0.728, 2.55), (-1.3, 0.0, 2.55), (-0.728, -1.3, 2.4),
    (-1.3, -0.728, 2.4), (-1.3, 0.0, 2.4), (-0.4, 0.224, 2.55), (-0.224, 0.4, 2.55),
    (0.0, 0.4, 2.55), (-1.3, 0.728, 2.55), (-0.728, 1.3, 2.55), (0.0, 1.3, 2.55),
    (-1.3, 0.728, 2.4), (-0.728, 1.3, 2.4), (0.0, 1.3, 2.4), (0.224, 0.4, 2.55),
    (0.4, 0.224, 2.55), (0.728, 1.3, 2.55), (1.3, 0.728, 2.55), (0.728, 1.3, 2.4),
    (1.3, 0.728, 2.4), (0.0, 0.0, 0.0), (1.5, 0.0, 0.15), (1.5, 0.84, 0.15),
    (0.84, 1.5, 0.15), (0.0, 1.5, 0.15), (1.5, 0.0, 0.075), (1.5, 0.84, 0.075),
    (0.84, 1.5, 0.075), (0.0, 1.5, 0.075), (1.425, 0.0, 0.0), (1.425, 0.798, 0.0),
    (0.798, 1.425, 0.0), (0.0, 1.425, 0.0), (-0.84, 1.5, 0.15), (-1.5, 0.84, 0.15),
    (-1.5, 0.0, 0.15), (-0.84, 1.5, 0.075), (-1.5, 0.84, 0.075), (-1.5, 0.0, 0.075),
    (-0.798, 1.425, 0.0), (-1.425, 0.798, 0.0), (-1.425, 0.0, 0.0), (-1.5, -0.84, 0.15),
    (-0.84, -1.5, 0.15), (0.0, -1.5, 0.15), (-1.5, -0.84, 0.075), (-0.84, -1.5, 0.075),
    (0.0, -1.5, 0.075), (-1.425, -0.798, 0.0), (-0.798, -1.425, 0.0), (0.0, -1.425, 0.0),
    (0.84, -1.5, 0.15), (1.5, -0.84, 0.15), (0.84, -1.5, 0.075), (1.5, -0.84, 0.075),
    (0.798, -1.425, 0.0), (1.425, -0.798, 0.0),
)
# fmt: on

# Z-up → Y-up: (x, y, z) → (x, z, -y). Determinant +1, so a rotation: it keeps the
# winding's handedness and maps normals with the same matrix.
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

# Quantum for welding coincident seam vertices, in data units (data spans ~7).
_WELD_QUANTUM = 1e-6


def _bernstein(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Bernstein basis and its derivative at parameters ``t``.

    Returns two (len(t), 4) arrays: ``B_i(t)`` and ``dB_i/dt``.
    """
    t = np.asarray(t, dtype=np.float64)[:, None]
    s = 1.0 - t
    basis = np.hstack([s**3, 3.0 * t * s**2, 3.0 * t**2 * s, t**3])
    deriv = np.hstack([-3.0 * s**2, 3.0 * s * (s - 2.0 * t), 3.0 * t * (2.0 * s - t), 3.0 * t**2])
    return basis, deriv


def _patch_points(ctrl: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Evaluate a 4×4×3 control net at the grid ``u`` × ``v`` → (len(u), len(v), 3)."""
    bu, _ = _bernstein(u)
    bv, _ = _bernstein(v)
    return np.einsum("ai,bj,ijk->abk", bu, bv, ctrl)


def _patch_normals(ctrl: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unnormalised outward normals ``∂P/∂v × ∂P/∂u`` on the grid ``u`` × ``v``.

    In the published table every patch's rows (u) run down the profile and its
    columns (v) clockwise seen from +z, so ``∂P/∂u × ∂P/∂v`` points into the solid
    for all 32 patches; the reversed product points out.
    """
    bu, du = _bernstein(u)
    bv, dv = _bernstein(v)
    pu = np.einsum("ai,bj,ijk->abk", du, bv, ctrl)
    pv = np.einsum("ai,bj,ijk->abk", bu, dv, ctrl)
    return np.cross(pv, pu)


def _unit_patch_normals(ctrl: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Unit outward normals on the grid ``t`` × ``t``, with the poles repaired.

    Where a whole edge of the control net collapses to one point (the knob apex and
    the bottom centre) ``∂P/∂v`` vanishes along that edge and the cross product is
    zero. There the normal is taken at a parameter nudged 1e-4 into the patch (its
    limit as the nudge shrinks is the surface normal approached from that side;
    welding then averages the approaches from all sides, giving the axis). Should
    that fail too, the axis itself (±z, by the sign of the patch's mean normal) is
    used: both poles lie on the axis of revolution. The result is never NaN.
    """
    n = _patch_normals(ctrl, t, t)
    length = np.linalg.norm(n, axis=-1)
    tiny = 1e-9 * max(float(np.max(length)), 1e-300)
    bad = np.argwhere(length <= tiny)
    if bad.size:
        inward = np.where(t < 0.5, t + 1e-4, t - 1e-4)
        for a, b in bad:
            for uu, vv in ((inward[a], t[b]), (t[a], inward[b]), (inward[a], inward[b])):
                m = _patch_normals(ctrl, np.array([uu]), np.array([vv]))[0, 0]
                if np.linalg.norm(m) > tiny:
                    break
            else:
                m = np.array([0.0, 0.0, 1.0 if np.sum(n[..., 2]) >= 0.0 else -1.0])
            n[a, b] = m
        length = np.linalg.norm(n, axis=-1)
    return n / length[..., None]


def _weld(
    points: np.ndarray, normals: np.ndarray, parts: np.ndarray, faces: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices of one part that coincide to ``_WELD_QUANTUM``.

    Positions of a merged vertex are averaged (they differ by rounding only);
    normals are summed and renormalised, which on the teapot's tangent-continuous
    seams only removes round-off and at the poles yields the axis.
    """
    key = np.column_stack([parts.astype(np.float64), np.round(points / _WELD_QUANTUM)])
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    # Number the welded vertices in order of first appearance, so output is stable.
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    index = rank[inverse]
    count = order.size
    weights = np.bincount(index, minlength=count).astype(np.float64)
    pos = np.zeros((count, 3))
    nrm = np.zeros((count, 3))
    np.add.at(pos, index, points)
    np.add.at(nrm, index, normals)
    pos /= weights[:, None]
    length = np.linalg.norm(nrm, axis=1)
    # Opposite normals meeting at one point would cancel; keep the first one then.
    cancelled = length < 1e-6 * weights
    nrm[cancelled] = normals[first[order][cancelled]]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    return pos, nrm, index[faces]


def _drop_degenerate(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Remove triangles with a repeated index or (numerically) zero area."""
    distinct = (
        (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    )
    faces = faces[distinct]
    tri = vertices[faces]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    edge = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
    return faces[area2 > 1e-12 * np.maximum(edge, 1e-300) ** 2]


def build_teapot(segments: int = SEGMENTS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tessellate the 32 Newell patches into one welded, outward-facing triangle mesh.

    Each patch is evaluated on a (segments + 1)² uniform parameter grid with the
    cubic Bernstein basis; its normals are the normalised ``∂P/∂v × ∂P/∂u``, which
    points out of the solid for all 32 published patches (see ``_patch_normals``).
    Each grid cell becomes two triangles wound counter-clockwise about that normal.
    Seam vertices are welded within each part (body with rim and bottom, handle,
    spout, lid), degenerate triangles at the two poles are dropped, and the result
    is rotated to Y-up and scaled by ``SCALE`` (see the module docstring).

    Returns ``(vertices, normals, faces)``: (N, 3) float64 positions, (N, 3)
    float64 unit normals and (M, 3) int64 indices, counter-clockwise seen from
    outside.
    """
    if segments < 1:
        raise ValueError(f"segments must be >= 1, got {segments}")
    control = np.asarray(VERTICES, dtype=np.float64)
    t = np.linspace(0.0, 1.0, segments + 1)
    n1 = segments + 1
    # Grid cell (a, b) → two triangles, counter-clockwise around ∂P/∂v × ∂P/∂u.
    a, b = np.meshgrid(np.arange(segments), np.arange(segments), indexing="ij")
    p00 = (a * n1 + b).ravel()
    p10 = ((a + 1) * n1 + b).ravel()
    p11 = ((a + 1) * n1 + b + 1).ravel()
    p01 = (a * n1 + b + 1).ravel()
    cell_faces = np.concatenate(
        [np.column_stack([p00, p11, p10]), np.column_stack([p00, p01, p11])]
    )

    points, normals, parts, faces = [], [], [], []
    for k, patch in enumerate(PATCHES):
        ctrl = control[np.asarray(patch) - 1].reshape(4, 4, 3)
        points.append(_patch_points(ctrl, t, t).reshape(-1, 3))
        normals.append(_unit_patch_normals(ctrl, t).reshape(-1, 3))
        parts.append(np.full(n1 * n1, _PART_OF_PATCH[k]))
        faces.append(cell_faces + k * n1 * n1)

    verts, norms, tris = _weld(
        np.concatenate(points),
        np.concatenate(normals),
        np.concatenate(parts),
        np.concatenate(faces),
    )
    tris = _drop_degenerate(verts, tris)
    # Drop vertices no face uses any more (none expected, but keep the mesh tidy).
    used = np.unique(tris)
    remap = np.full(len(verts), -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    verts, norms, tris = verts[used], norms[used], remap[tris]

    verts = verts @ _Z_UP_TO_Y_UP.T * SCALE
    norms = norms @ _Z_UP_TO_Y_UP.T
    norms /= np.linalg.norm(norms, axis=1)[:, None]
    return verts, norms, tris.astype(np.int64)


def write_obj(
    path: str | os.PathLike[str],
    vertices: np.ndarray,
    normals: np.ndarray,
    faces: np.ndarray,
) -> None:
    """Write a Wavefront OBJ with ``v``, ``vn`` and ``f a//a`` lines, atomically.

    Positions and normals share indices (one normal per vertex), so faces use the
    ``a//a`` form. Six decimals keep the positions to ~1e-6 of a 1-unit model. The
    text goes to a temporary file in the destination folder and is moved over the
    target with ``os.replace``, so a reader never sees a half-written mesh.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if vertices.shape != normals.shape or vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError("vertices and normals must both be (N, 3) arrays")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError("faces must be an (M, 3) array")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ValueError("face index out of range")

    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    header = (
        "# Utah teapot (Newell 1975; patch data as published by Crow 1987), Y-up, 1 unit tall\n"
        f"# generated by app/assets/teapot.py: {len(vertices)} vertices, {len(faces)} faces\n"
    )
    # Round first, then add 0.0: turns -0.0 (and tiny negatives) into "0.000000" so
    # regenerated files diff cleanly.
    v_rows = np.round(vertices, 6) + 0.0
    vn_rows = np.round(normals, 6) + 0.0
    v_text = "".join("v {:.6f} {:.6f} {:.6f}\n".format(*row) for row in v_rows)
    vn_text = "".join("vn {:.6f} {:.6f} {:.6f}\n".format(*row) for row in vn_rows)
    f_text = "".join("f {0}//{0} {1}//{1} {2}//{2}\n".format(*row) for row in faces + 1)

    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="ascii", newline="\n") as fh:
            fh.write(header)
            fh.write(v_text)
            fh.write(vn_text)
            fh.write(f_text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def default_obj_path() -> Path:
    """``scenes/meshes/teapot.obj`` under the repository root (two levels above this package)."""
    return Path(__file__).resolve().parents[2] / "scenes" / "meshes" / "teapot.obj"


def main() -> None:
    """Build the teapot at the default resolution and write ``scenes/meshes/teapot.obj``."""
    vertices, normals, faces = build_teapot(SEGMENTS)
    path = default_obj_path()
    write_obj(path, vertices, normals, faces)
    print(f"wrote {path}: {len(vertices)} vertices, {len(faces)} faces")


if __name__ == "__main__":
    main()
