"""The area lights and shading points the LTC twin is measured on (docs/area_lights.md,
"Error against the truth"): one light of each shape over a dielectric floor and a seeded
set of floor points seen from many directions. tests/test_area_lights.py bounds the twin's
error on them and scripts/area_light_errors.py writes docs/area_lights.md's tables from
them, so that the tables and the tests' budgets speak of the same set.
"""

from __future__ import annotations

import math

import numpy as np

from app.common.lights import LightType, PunctualLight
from app.common.models import ModelParams
from app.reference.material import ShadingPoint, Surface

ZERO = np.zeros(3)


def unit_light(kind: LightType, centre, u=ZERO, w=ZERO, radius: float = 0.0) -> PunctualLight:
    """An area light of radiance 1 and range 10 m: centre, half-extent vectors ``u`` and
    ``w`` (a rectangle's or disk's; a tube's half axis ``u``) and ``radius`` (sphere, tube)."""
    u, w = np.asarray(u, float), np.asarray(w, float)
    return PunctualLight(kind, np.asarray(centre, float), ZERO, np.ones(3), 10.0,
                         axis_u=u, axis_v=w, radius=radius)  # fmt: skip


def sample_lights() -> list[PunctualLight]:
    """One light of each shape (rectangle, disk, sphere, tube), 0.9 to 1.2 m over the
    floor y = 0, facing it."""
    return [
        unit_light(LightType.RECT, [0.3, 1.2, 0.2], [0.5, 0.0, 0.0], [0.0, 0.0, 0.25]),
        unit_light(LightType.DISK, [-0.4, 1.0, 0.3], [0.35, 0.0, 0.0], [0.0, 0.1, 0.336]),
        unit_light(LightType.SPHERE, [0.5, 0.9, -0.3], radius=0.3),
        unit_light(LightType.TUBE, [0.0, 1.1, -0.2], [0.6, 0.0, 0.1], radius=0.06),
    ]


def floor_points(roughness: float, count: int = 16) -> ShadingPoint:
    """``count`` points on the floor y = 0 near the origin (a grey dielectric, F0 0.04, of
    perceptual ``roughness``), viewed from 30 to 80 degrees off the normal; seeded, so the
    same set every time."""
    rng = np.random.default_rng(3)
    p = np.stack([rng.uniform(-0.8, 0.8, count), np.zeros(count), rng.uniform(-0.8, 0.8, count)], 1)
    elev = np.radians(rng.uniform(10.0, 60.0, count))
    az = rng.uniform(0.0, 2.0 * math.pi, count)
    v = np.stack([np.cos(elev) * np.cos(az), np.sin(elev), np.cos(elev) * np.sin(az)], 1)
    n = np.broadcast_to([0.0, 1.0, 0.0], p.shape)
    s = Surface(np.full((count, 3), 0.5), np.zeros(count), np.full(count, roughness),
                np.full(count, 0.04), np.zeros(count))  # fmt: skip
    t = np.broadcast_to([1.0, 0.0, 0.0], p.shape)
    return ShadingPoint(s, ModelParams(), n, None, t, v, p)
