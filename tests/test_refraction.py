"""The ray-caster's exact refraction through analytic spheres (app/reference/refraction.py),
against closed forms, and the transmission pass against it where the screen-space method
is exact (docs/transmission.md)."""

from __future__ import annotations

import numpy as np
import pytest

from app.common.ior import f0_from_ior
from app.common.models import Model, ModelParams
from app.common.primitives import Primitive
from app.reference.material import Surface
from app.reference.raycast import PrimitiveMaterial
from app.reference.refraction import sphere_exit, transmitted_exact
from app.reference.transmission import refracted_direction

RADIUS = 0.5


def glass(ior: float, thickness: float, color=(1.0, 1.0, 1.0), distance: float = 0.0):
    """A white glass sphere at the origin and an emitter-free wall behind it; the wall's
    radiance along any ray is the background colour here (no lights): what matters is the
    weight the exact path gives it."""
    params = ModelParams(
        eta_dielectric=ior, transmission=1.0, thickness=thickness,
        attenuation_color=np.array(color), attenuation_distance=distance,
    )  # fmt: skip
    surface = Surface(np.ones(3), 0.0, 0.0, float(f0_from_ior(ior)), 0.0)
    return Primitive("sphere", np.eye(4), radius=RADIUS), PrimitiveMaterial(
        surface, params, Model()
    )


def test_snell_and_the_chord():
    """Refraction keeps n1 sin = n2 sin; the far root from the entry point along the
    refracted ray is the chord 2 R cos(theta_t)."""
    prim, _ = glass(1.5, 1.0)
    theta = 0.6
    n = np.array([[np.sin(theta), 0.0, np.cos(theta)]])
    p = RADIUS * n
    v = np.array([[0.0, 0.0, 1.0]])
    d = refracted_direction(v, n, np.array([1.5]))
    sin_t = np.linalg.norm(np.cross(d[0], -n[0]))
    assert np.isclose(np.sin(theta), 1.5 * sin_t)
    chord = sphere_exit(prim, p, d)
    assert np.isclose(chord[0], 2.0 * RADIUS * np.sqrt(1.0 - sin_t**2))


@pytest.mark.parametrize("ior", [1.33, 1.5])
def test_a_ray_through_the_centre(ior):
    """Through the centre: two normal-incidence interfaces, (1 - F(0))^2 with the exact
    F(0) = ((n - 1)/(n + 1))^2, and Beer-Lambert over the diameter, c^(2R / D). Fails
    with one interface's Fresnel or the thickness number (not the chord) as the path."""
    prim, mat = glass(ior, 0.3, color=(0.5, 0.8, 1.0), distance=0.5)
    n = np.array([[0.0, 0.0, 1.0]])
    p = RADIUS * n
    background = np.array([0.2, 0.4, 0.6])
    L, unseen = transmitted_exact([prim], [mat], 0, [], background, p, n, n)
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    tint = np.array([0.5, 0.8, 1.0]) ** (2.0 * RADIUS / 0.5)
    # rtol: the 1e-9 m offsets the rays start with lengthen the path by that much
    np.testing.assert_allclose(L[0], (1.0 - f0) ** 2 * tint * background, rtol=1e-8)
    assert unseen[0] == 1.0  # it reaches the background: a screen-space lookup cannot


def test_thin_walled_passes_straight_on():
    """Thin-walled: the ray goes on unbent, weighted by 1 - F_schlick(n.v)."""
    prim, mat = glass(1.5, 0.0)
    theta = 0.8
    n = np.array([[np.sin(theta), 0.0, np.cos(theta)]])
    v = np.array([[0.0, 0.0, 1.0]])
    background = np.array([1.0, 1.0, 1.0])
    L, _ = transmitted_exact([prim], [mat], 0, [], background, RADIUS * n, n, v)
    f0 = 0.04
    expected = 1.0 - (f0 + (1.0 - f0) * (1.0 - np.cos(theta)) ** 5)
    np.testing.assert_allclose(L[0], expected, rtol=1e-12)


@pytest.mark.gl
def test_thin_smooth_glass_matches_the_ray_caster(gl_egl):
    """The screen-space method is exact for a thin-walled smooth sphere before a lit wall
    (the straight ray reaches the texel the pixel shows): relative RMSE against the exact
    refraction below 1e-5 (measured 1.1e-7 at 160x120). Fails if the pass offsets a
    thin-walled lookup or weighs it otherwise than (1 - F)."""
    from app.bench.transmission import CASES, case_errors

    errors = case_errors(gl_egl, CASES[0], (64, 48), 1)
    assert errors["pixels"] > 100
    assert errors["rel_rmse"] < 1e-5, errors
