"""Physics of the float64 reference BRDF (app/reference), proved by numerical quadrature.

Each test states one claim of RTR4 chapter 9 ("Physically Based Shading") as an integral over
the hemisphere and evaluates it with a deterministic quadrature (Gauss-Legendre, no Monte
Carlo noise), so each tolerance is tight: far below any error a wrong factor, exponent or
clamp would cause, and checked against the quadrature's own convergence. Conventions as in
app/reference: n = +Z, vectors have a last axis of 3, alpha = roughness^2.

The quadrature rules live in app/reference/quadrature.py; the first tests here check them.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.reference.diffuse import Fd_lambert
from app.reference.fresnel import F_schlick
from app.reference.masking import (
    G1_smith,
    G2_height_correlated_GGX,
    Lambda_GGX,
    V_height_correlated_GGX,
)
from app.reference.material import Surface, brdf_standard
from app.reference.ndf import D_GGX
from app.reference.quadrature import (
    N,
    cosine_rule,
    direction,
    directional_albedo,
    facing_limit,
    reflected_rule,
    tan_rule,
)
from app.reference.specular import f_spec_GGX


def specular_albedo(roughness: float, l: np.ndarray, n_psi: int = 32, n_phi: int = 32) -> float:
    """E(l) = integral of f_spec(l, v) (n.v) dv with F0 = 1 (F = 1): the GGX single scattering."""
    alpha = roughness * roughness
    v, w = reflected_rule(l, alpha, n_psi, n_phi)
    return float(directional_albedo(f_spec_GGX(1.0, alpha, N, l, v), v, w)[0])


ALPHAS = (0.002, 0.01, 0.05, 0.1, 0.2, 0.5, 0.8, 1.0)  # 0.002 ~ the 0.045 roughness floor
ROUGHNESSES = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 1.0)
THETA_L = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0)


# --- the quadrature rules themselves -------------------------------------------------------


@pytest.mark.parametrize("scale", [0.002, 0.1, 1.0, 4.0])
def test_rules_measure_the_hemisphere(scale: float) -> None:
    """Solid angle 2 pi and projected solid angle pi, from both hemisphere rules."""
    for d, w in (cosine_rule(8, 8), tan_rule(scale, 32, 8)):
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-14)
        assert (d[:, 2] > 0.0).all()
        assert np.sum(w) == pytest.approx(2.0 * np.pi, rel=1e-12)
        assert np.sum(w * d[:, 2]) == pytest.approx(np.pi, rel=1e-12)


@pytest.mark.parametrize("theta_l", [0.0, 40.0, 80.0, 89.0])
@pytest.mark.parametrize("scale", [0.25, 0.5, 1.0])
def test_reflected_rule_jacobian(theta_l: float, scale: float) -> None:
    """Through the half-vector map, integral of (n.v) dv over the upper hemisphere is pi."""
    l = direction(theta_l, 30.0)
    v, w = reflected_rule(l, scale, 32, 16)
    assert (v @ N > 0.0).all()
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-13)
    assert np.sum(w * (v @ N)) == pytest.approx(np.pi, rel=1e-10)


# --- 1. white furnace ------------------------------------------------------------------------


@pytest.mark.parametrize("theta_l", [0.0, 30.0, 60.0, 85.0, 89.0])
def test_white_lambertian_reflects_all_it_receives(theta_l: float) -> None:
    """RTR4 §9.3: a white Lambertian surface (rho_ss = 1) has directional albedo 1.

    The white furnace, by two rules over v: the plain one and the half-vector one around l.
    A coloured rho_ss comes back channel by channel.
    """
    l = direction(theta_l, 70.0)
    for v, w in (cosine_rule(4, 4), reflected_rule(l, 0.5, 16, 8)):
        for rho in (np.ones(3), np.array([0.9, 0.5, 0.05])):
            f = np.broadcast_to(Fd_lambert(rho), v.shape)
            np.testing.assert_allclose(directional_albedo(f, v, w), rho, rtol=0, atol=1e-12)


# --- 2. NDF normalisation --------------------------------------------------------------------


@pytest.mark.parametrize("alpha", ALPHAS)
def test_ggx_ndf_is_normalised(alpha: float) -> None:
    """The GGX NDF (RTR4 §9.8) is normalised: integral D(m)(n.m) dm = 1.

    Rules scaled to alpha/4, alpha and 4 alpha all agree: with scale = alpha the substitution
    makes the integrand sin(psi)cos(psi)/pi, but a mismatched scale converges too, so the
    result is no artefact of the substitution (a plain rule in cos(theta) with 64 points is
    off by 3e-3 at alpha = 0.05).
    """
    for scale in (alpha / 4.0, alpha, 4.0 * alpha):
        m, w = tan_rule(scale, 32, 4)
        assert np.sum(D_GGX(N, m, alpha) * (m @ N) * w) == pytest.approx(1.0, abs=1e-9)
    # The lower hemisphere holds no microfacets (chi+(n.m)).
    m, _ = tan_rule(alpha, 8, 4)
    assert (D_GGX(N, -m, alpha) == 0.0).all()


# --- 3. Smith projected-area condition -------------------------------------------------------


@pytest.mark.parametrize("theta_v", [0.0, 30.0, 60.0, 80.0, 89.0])
@pytest.mark.parametrize("alpha", ALPHAS)
def test_smith_masking_projected_area(alpha: float, theta_v: float) -> None:
    """RTR4 §9.7: integral G1(m, v) D(m) (v.m)+ dm = v.n, the visible projected area.

    G1(m, v) = chi+(m.v) / (1 + Lambda(v)); the rule is cut at m.v = 0, where (v.m)+ has its
    kink. Worst relative error over the grid: 3e-11 at these sizes (1e-8 at 32, 1e-6 at 16).
    """
    v = direction(theta_v, 20.0)
    m, w = tan_rule(alpha, 48, 48, tan_limit=facing_limit(v), azimuth=np.radians(20.0))
    G1 = G1_smith(Lambda_GGX(v @ N, alpha))
    projected = np.sum(G1 * D_GGX(N, m, alpha) * np.maximum(m @ v, 0.0) * w)
    assert projected == pytest.approx(v @ N, rel=1e-9)


# --- 4. visibility term ----------------------------------------------------------------------


def test_visibility_is_G2_over_4_NoL_NoV() -> None:
    """RTR4 §9.8: V = G2 / (4 |n.l| |n.v|); the GLSL's division-free form is the same."""
    c = np.concatenate([np.geomspace(1e-3, 1.0, 40), [0.05, 0.5, 0.7071, 0.99999]])
    NoL, NoV, alpha = np.meshgrid(c, c, np.array([*ALPHAS, 0.3, 0.045**2, 1e-4]), indexing="ij")
    V = V_height_correlated_GGX(NoL, NoV, alpha)
    np.testing.assert_allclose(
        V, G2_height_correlated_GGX(NoL, NoV, alpha) / (4.0 * NoL * NoV), rtol=1e-12, atol=0
    )
    # G2 itself: 1 at normal incidence on both sides, in (0, 1], and symmetric in l and v.
    np.testing.assert_allclose(G2_height_correlated_GGX(1.0, 1.0, alpha), 1.0, rtol=1e-15)
    G2 = G2_height_correlated_GGX(NoL, NoV, alpha)
    assert ((G2 > 0.0) & (G2 <= 1.0)).all()
    np.testing.assert_allclose(G2, G2_height_correlated_GGX(NoV, NoL, alpha), rtol=1e-15)


# --- 5. specular energy ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def specular_albedo_table() -> np.ndarray:
    """E[roughness, theta_l] for ROUGHNESSES x THETA_L (F0 = 1)."""
    return np.array([[specular_albedo(r, direction(t)) for t in THETA_L] for r in ROUGHNESSES])


def test_ggx_specular_never_creates_energy(specular_albedo_table: np.ndarray) -> None:
    """With F = 1 the GGX specular (RTR4 §9.8) reflects at most what it receives: E(l) <= 1."""
    E = specular_albedo_table
    # The quadrature's error: a coarser rule agrees to 1e-7 (measured 5e-8, and the rule
    # used is ~10x closer still).
    coarse = np.array(
        [[specular_albedo(r, direction(t), 24, 24) for t in THETA_L] for r in ROUGHNESSES]
    )
    np.testing.assert_allclose(E, coarse, rtol=0, atol=1e-7)
    assert E.max() <= 1.0 + 1e-7
    assert E.min() > 0.3
    # Smooth surfaces lose almost nothing away from grazing.
    assert (E[0, :6] > 0.9999).all()


def test_ggx_specular_loses_energy_when_rough(specular_albedo_table: np.ndarray) -> None:
    """Single scattering drops light that bounces more than once between microfacets (the RTR4's
    energy loss), most for rough surfaces near normal incidence.

    At roughness 1 (alpha = 1) D = 1/pi and V = 1/(2(n.l + n.v)), so E(mu_l) has a closed
    form, 1 - mu_l ln(1 + 1/mu_l): 1 - ln 2 = 0.307 at normal incidence.
    """
    E = specular_albedo_table
    mu_l = np.cos(np.radians(THETA_L))
    np.testing.assert_allclose(E[-1], 1.0 - mu_l * np.log1p(1.0 / mu_l), rtol=1e-8)
    assert E[-1, 0] < 0.35
    assert (E[-2:, :5] < 0.6).all()  # roughness >= 0.85, theta_l <= 60 degrees
    # At normal incidence the loss grows with roughness.
    assert (np.diff(E[:, 0]) < 0.0).all()


# --- 6. reciprocity --------------------------------------------------------------------------


def _upper_hemisphere(rng: np.random.Generator, count: int) -> np.ndarray:
    d = rng.normal(size=(count, 3))
    d[:, 2] = np.abs(d[:, 2])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


MATERIALS = {
    "dielectric": Surface(np.array([0.8, 0.2, 0.1]), 0.0, 0.5, 0.04),
    "metal": Surface(np.array([1.0, 0.71, 0.29]), 1.0, 0.3, 0.04),
    "rough": Surface(np.array([0.5, 0.5, 0.5]), 0.0, 1.0, 0.04),
    "smooth": Surface(np.array([0.05, 0.3, 0.9]), 0.0, 0.0, 0.04),  # floored to 0.045
    "smooth metal": Surface(np.array([0.95, 0.93, 0.88]), 1.0, 0.05, 0.04),
    "half metal": Surface(np.array([0.6, 0.6, 0.2]), 0.5, 0.6, 0.02),
}


@pytest.mark.parametrize("name", list(MATERIALS))
def test_brdf_is_reciprocal(name: str) -> None:
    """Helmholtz reciprocity: f(l, v) = f(v, l), for random pairs above the horizon.

    h = normalize(l + v) and V are symmetric by construction; F(v.h) vs F(l.h) differ by
    rounding only (measured: at most 7e-15 relative over these materials).
    """
    rng = np.random.default_rng(1760)
    l, v = _upper_hemisphere(rng, 5000), _upper_hemisphere(rng, 5000)
    keep = (l @ N > 1e-3) & (v @ N > 1e-3)  # the GLSL clamps n.v to 1e-4, but not n.l
    l, v = l[keep], v[keep]
    assert len(l) > 4900
    s = MATERIALS[name]
    f_lv = brdf_standard(s, N, l, v)
    assert (f_lv > 0.0).all()
    np.testing.assert_allclose(f_lv, brdf_standard(s, N, v, l), rtol=1e-12, atol=0)


# --- 7. Fresnel ------------------------------------------------------------------------------


def test_schlick_fresnel_from_F0_to_one() -> None:
    """RTR4 §9.5: F(0 degrees) = F0 and F(90 degrees) = 1 exactly; F falls as cos rises."""
    F0 = np.concatenate([np.linspace(0.0, 1.0, 1001), [0.02, 0.04, 0.045, 0.08]])
    np.testing.assert_array_equal(F_schlick(F0, 1.0), F0)
    np.testing.assert_array_equal(F_schlick(F0, 0.0), np.ones_like(F0))
    rgb = np.array([1.0, 0.71, 0.29])
    np.testing.assert_array_equal(F_schlick(rgb, 1.0), rgb)
    np.testing.assert_array_equal(F_schlick(rgb, 0.0), np.ones(3))

    cos = np.linspace(0.0, 1.0, 101)
    F = F_schlick(F0[F0 < 1.0], cos)  # (cos, F0)
    assert (np.diff(F, axis=0) < 0.0).all()
    fine = F_schlick(F0[::10], np.linspace(0.0, 1.0, 100001))
    assert (np.diff(fine, axis=0) <= 0.0).all()
    assert ((fine >= F0[::10]) & (fine <= 1.0)).all()
