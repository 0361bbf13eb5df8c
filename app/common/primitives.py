"""Exact analytic primitives: what the G-buffer pass ray-casts per pixel instead of drawing
triangles, and what the float64 ray-caster (app/reference/raycast.py) intersects.

A primitive is given in its object space (centred on the origin) and placed by a model
matrix (object -> world, any affine map: scale, rotation, translation), so a scaled sphere
is an ellipsoid. Both sides derive the surface frame the same way, from the object-space
hit point ``q``:

* sphere of radius ``r``: the normal is ``q / r`` taken to the world by the inverse
  transpose of the model matrix; the tangent runs around the object's +Y axis
  (``Y x n``, ``X x n`` at the poles) taken to the world by the model matrix; UVs are
  equirectangular, ``u = atan2(n.x, n.z) / 2 pi + 0.5`` and ``v = asin(n.y) / pi + 0.5``
  of the object-space unit normal (the icosphere's UVs, app/scene/geometry.py);
* plane of size ``(sx, sz)``: the rectangle |x| <= sx/2, |z| <= sz/2 of the object's XZ
  plane, normal +Y (flipped towards the viewer: planes are two-sided), tangent +X,
  ``u = x / sx + 0.5``, ``v = 0.5 - z / sz``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

PrimitiveKind = Literal["sphere", "plane"]


@dataclass(frozen=True)
class Primitive:
    """One analytic primitive in the world: its kind, its object-space size and its model
    matrix (object -> world, float64)."""

    kind: PrimitiveKind
    model: np.ndarray  # (4, 4) float64
    radius: float = 0.0  # sphere (m)
    size: tuple[float, float] = (0.0, 0.0)  # plane: extent along object X and Z (m)
