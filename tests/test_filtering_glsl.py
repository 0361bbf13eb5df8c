"""Geometric specular antialiasing (RTR4 §9.13): glsl/material/filtering.glsl against its
float64 twin app/reference/filtering.py, on EGL and OSMesa, and what the kernel may do.

GLSL-vs-twin: the twin gets the float32-rounded inputs the shader received, so what is left
is float32 arithmetic. alpha2_specular_aa: two dot products of 3 positive terms (<= 3
roundings each), their sum, the product by sigma2, the exact doubling and min, the sum with
alpha2 (all terms >= 0, so relative errors do not grow): <= 6 roundings of U = 2^-24, i.e.
3.6e-7. perceptual_roughness_specular_aa adds r^4 (3 roundings) before, and two square roots
(each halves the relative error and adds one rounding) after. Bound asserted: 1e-6 (~17 U).
Values below 1e-30 are compared absolutely: float32 flushes below 1.2e-38 (derivatives
< 1e-19 square to 0 on the GPU, not in float64). LEAN's covariance-to-roughness conversion
(lean_anisotropic_roughness) is compared by its outputs' absolute error and axis.
"""

from __future__ import annotations

import numpy as np

from app.gl.context import GLContext
from app.gl.kernel import run_kernel
from app.reference.filtering import (
    GGX_LEAN_SPREAD,
    SPECULAR_AA_KAPPA,
    SPECULAR_AA_SIGMA2,
    alpha2_specular_aa,
    lean_anisotropic_roughness,
    perceptual_roughness_specular_aa,
)
from tests.agreement import relative_error

INCLUDES = ["material/filtering.glsl"]
RNG_SEED = 20241130
MAX_REL_ERR = 1e-6
U = 2.0**-24
BODY = """
result = vec4(alpha2_specular_aa(p.x, dx.xyz, dy.xyz, p.y, p.z),
              perceptual_roughness_specular_aa(p.w, dx.xyz, dy.xyz, p.y, p.z), 0.0, 1.0);
"""


def f32(a: np.ndarray) -> np.ndarray:
    """The float32 value the shader receives, back in float64 for the twin."""
    return np.asarray(a, np.float32).astype(np.float64)


def aa_inputs(n: int = 6000) -> dict[str, np.ndarray]:
    """alpha2 and r uniform in [0, 1] with the ends and the roughness floor; derivatives of
    random direction and magnitude 10^U(-25, 30) (to float32's overflow of their squares and
    past it), a seventh of them zero in both, a seventh zero in one; sigma2 and kappa the
    defaults for half the rows, else uniform over the scene format's ranges (0, 10], [0, 1]."""
    rng = np.random.default_rng(RNG_SEED)

    def derivative() -> np.ndarray:
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return d * 10.0 ** rng.uniform(-25.0, 30.0, (n, 1))

    dndx, dndy = derivative(), derivative()
    dndx[::7] = 0.0
    dndy[::7] = 0.0
    dndy[3::7] = 0.0
    edges = np.array([0.0, 1.0, 0.045**4, 0.5])
    alpha2 = rng.uniform(0.0, 1.0, n)
    alpha2[: len(edges)] = edges
    r = rng.uniform(0.0, 1.0, n)
    r[: len(edges)] = [0.0, 1.0, 0.045, 0.5]
    default = rng.uniform(size=n) < 0.5
    sigma2 = np.where(default, SPECULAR_AA_SIGMA2, rng.uniform(1e-3, 10.0, n))
    kappa = np.where(default, SPECULAR_AA_KAPPA, rng.uniform(0.0, 1.0, n))
    return {
        "p": f32(np.stack([alpha2, sigma2, kappa, r], axis=-1)),
        "dx": f32(dndx),
        "dy": f32(dndy),
    }


def test_specular_aa_glsl_matches_twin(gl: GLContext) -> None:
    """Measured on llvmpipe, EGL and OSMesa alike: 7.8e-8 (alpha2, 1.3 U) and 9.6e-8
    (r, 1.6 U) relative at most, against the 1e-6 bound."""
    x = aa_inputs()
    p = x["p"]
    out = run_kernel(gl.ctx, INCLUDES, BODY, x)
    assert np.all(np.isfinite(out))
    ref_a2 = alpha2_specular_aa(p[:, 0], x["dx"], x["dy"], p[:, 1], p[:, 2])
    ref_r = perceptual_roughness_specular_aa(p[:, 3], x["dx"], x["dy"], p[:, 1], p[:, 2])
    err_a2 = relative_error(out[:, 0], ref_a2, 1e-30)
    err_r = relative_error(out[:, 1], ref_r, 1e-30)
    assert err_a2.max() <= MAX_REL_ERR, f"alpha2_specular_aa: {err_a2.max():.2e}"
    assert err_r.max() <= MAX_REL_ERR, f"perceptual_roughness_specular_aa: {err_r.max():.2e}"


def test_zero_derivatives_leave_alpha2_unchanged(gl: GLContext) -> None:
    """A flat pixel (dn/dx = dn/dy = 0): alpha2 + 0 is alpha2 bit for bit; r comes back
    through r^4 and two square roots, within 3 U (measured: bit for bit here too)."""
    x = aa_inputs()
    still = ~np.any(x["dx"] != 0.0, axis=-1) & ~np.any(x["dy"] != 0.0, axis=-1)
    assert still.sum() > 800
    out = run_kernel(gl.ctx, INCLUDES, BODY, {k: v[still] for k, v in x.items()})
    p = x["p"][still]
    np.testing.assert_array_equal(out[:, 0], p[:, 0])
    assert relative_error(out[:, 1], p[:, 3], 1e-30).max() <= 3 * U


def test_kernel_adds_at_most_kappa(gl: GLContext) -> None:
    """alpha2 <= alpha2' <= alpha2 + kappa (+ the final float32 rounding, <= 2^-25 below 1),
    and huge derivatives (|dn| >= 1e10, squares up to float32's +Inf) add exactly kappa,
    up to the clamp at 1: silhouettes cannot make a mirror fully rough."""
    x = aa_inputs()
    p = x["p"]
    out = run_kernel(gl.ctx, INCLUDES, BODY, x)[:, 0]
    added = out - p[:, 0]
    assert added.min() >= 0.0
    assert np.max(added - p[:, 2]) <= 2.0**-25
    huge = np.maximum(np.abs(x["dx"]).max(axis=-1), np.abs(x["dy"]).max(axis=-1)) >= 1e10
    assert huge.sum() > 1500
    want = np.minimum(p[huge, 0] + p[huge, 2], 1.0)
    np.testing.assert_allclose(out[huge], want, rtol=0, atol=2.0**-24)


def test_sigma2_is_the_pixel_filter_variance() -> None:
    """The kernel's meaning: a normal rotating at k radians per pixel about y,
    n(x) = (sin kx, 0, cos kx), has |dn/dx| = k; under a Gaussian pixel filter of variance
    sigma2 (pixels^2) its slope tan(kx) has variance k^2 sigma2 + O(k^4), and the twin's
    kernel is twice that (alpha^2 gains 2 Var(slope) for Beckmann). Gauss-Hermite quadrature
    of the slope variance, k = 1e-3 .. 2e-2: agreement to 4e-4 relative (the O(k^2) term)."""
    t, w = np.polynomial.hermite_e.hermegauss(40)  # nodes of N(0, 1), weights sum to sqrt(2 pi)
    w = w / w.sum()
    for k in (1e-3, 5e-3, 2e-2):
        x = t * np.sqrt(SPECULAR_AA_SIGMA2)
        s = np.tan(k * x)
        var = np.sum(w * s * s) - np.sum(w * s) ** 2
        dndx = np.array([k, 0.0, 0.0])  # d/dx of (sin kx, 0, cos kx) at x = 0
        kernel = alpha2_specular_aa(0.0, dndx, np.zeros(3), SPECULAR_AA_SIGMA2, 1.0)
        assert abs(kernel / (2.0 * var) - 1.0) <= 4e-4


LEAN_BODY = """
vec4 lean = lean_anisotropic_roughness(p.x, p.y, d.xy, s.xyz, p.z);
result = lean;
"""


def lean_inputs(n: int = 4000) -> dict[str, np.ndarray]:
    """Olano & Baker 2010's conversion on random materials and covariances: r in [0, 1],
    anisotropy in [-1, 1] (a quarter 0), a unit direction, and a positive semi-definite
    Sigma of eigenvalues 10^U(-6, 0) (a quarter of them rank 1, an eighth 0) at a random
    angle; the spread factor Beckmann's 1 or GGX_LEAN_SPREAD, half each."""
    rng = np.random.default_rng(RNG_SEED + 1)
    r = rng.uniform(0.0, 1.0, n)
    a = np.where(rng.uniform(size=n) < 0.25, 0.0, rng.uniform(-1.0, 1.0, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    theta = rng.uniform(0.0, np.pi, n)
    lam = 10.0 ** rng.uniform(-6.0, 0.0, (n, 2))
    lam[::4, 1] = 0.0
    lam[::8] = 0.0
    c, s = np.cos(theta), np.sin(theta)
    sigma = np.stack(
        [lam[:, 0] * c * c + lam[:, 1] * s * s, lam[:, 0] * s * s + lam[:, 1] * c * c,
         (lam[:, 0] - lam[:, 1]) * c * s], axis=-1,
    )  # fmt: skip
    return {
        "p": f32(np.stack([r, a, np.where(rng.uniform(size=n) < 0.5, 1.0, GGX_LEAN_SPREAD)], -1)),
        "d": f32(np.stack([np.cos(phi), np.sin(phi)], axis=-1)),
        "s": f32(sigma),
    }


def test_lean_glsl_matches_twin(gl: GLContext) -> None:
    """lean_anisotropic_roughness against its twin on the float32 inputs: r' within 1e-4 and
    a' within 1e-3 absolute (measured on llvmpipe 3.3e-5 and 2.6e-4: the minor eigenvalue
    m - q loses float32's digits where the sum is nearly rank 1, and alpha_y' = sqrt(m - q)
    amplifies that where it is tiny), and the direction the same axis, |d'.d| >= 1 - 1e-5
    (measured 1 - 1.1e-7), wherever a' > 1e-3 (elsewhere every axis is nearly one)."""
    x = lean_inputs()
    p = x["p"]
    out = run_kernel(gl.ctx, INCLUDES, LEAN_BODY, x)
    assert np.all(np.isfinite(out))
    r, a, d = lean_anisotropic_roughness(p[:, 0], p[:, 1], x["d"][:, :2], x["s"], p[:, 2])
    assert np.abs(out[:, 0] - r).max() <= 1e-4
    assert np.abs(out[:, 1] - a).max() <= 1e-3
    assert np.allclose(np.linalg.norm(out[:, 2:], axis=-1), 1.0, atol=1e-6)
    distinct = a > 1e-3
    assert distinct.sum() > 2000
    axis = np.abs(np.sum(out[:, 2:] * d, axis=-1))
    assert axis[distinct].min() >= 1.0 - 1e-5
