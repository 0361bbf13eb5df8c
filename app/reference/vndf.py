"""Sampling the GGX distribution of visible normals (RTR4 §9.6-9.8), float64.

Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4): a microfacet
normal m seen from v is drawn with the density of the visible normals (Heitz 2014, eq. 38;
RTR4 §9.6)

    D_v(m) = G1(v) (v.m)+ D(m) / (n.v),

which integrates to 1 over the hemisphere of m (the projected-area condition of RTR4
§9.7). The method stretches the view by the roughness into the configuration where the
microsurface is a hemisphere of unit radius, samples the projected area of that
hemisphere (a disc, of which the half the view cannot see is squeezed onto the rest), and
unstretches the normal. The reflected direction l = 2 (v.m) m - v then has the density

    p(l) = D_v(m) / (4 (v.m)) = G1(v) D(m) / (4 n.v),

so the estimator of the directional albedo E(v) = int f_spec (n.l) dl of a microfacet BRDF
F G2 D / (4 n.l n.v) is F G2 / G1(v) per sample: the D and the cosines cancel, and only
the shadowing of l remains (zero where l falls below the horizon). Formulas from the
paper, the code is this project's.

Conventions as app/reference: n = +Z, tangent frame x, y; directions unit, last axis 3;
alpha = r^2 (isotropic here; alpha_x, alpha_y for the anisotropic case).
"""

from __future__ import annotations

import numpy as np

from app.reference import masking
from app.reference.ndf import D_GGX
from app.reference.specular import f_spec_GGX

N = np.array([0.0, 0.0, 1.0])
VNDF_METHODS = ("vndf", "cosine", "uniform")  # the albedo estimators of albedo_samples


def sample_vndf(
    v: np.ndarray, alpha_x: float, alpha_y: float, u1: np.ndarray, u2: np.ndarray
) -> np.ndarray:
    """Heitz 2018, listing 1: microfacet normals m (M, 3) distributed as D_v for the view v
    (unit, n.v > 0) from uniform numbers u1, u2 (M,) in [0, 1). The listing of the uniform
    environment's ``sample_ggx_vndf`` (app/reference/environment_uniform.py, the GLSL's
    twin, one (u1, u2) per call), here over arrays of numbers: tests/test_vndf_sampling.py
    checks the two agree."""
    v = np.asarray(v, np.float64)
    # 1. the view in the stretched (hemisphere) configuration
    vh = np.array([alpha_x * v[0], alpha_y * v[1], v[2]])
    vh /= np.linalg.norm(vh)
    # 2. an orthonormal basis around it (T1 in the tangent plane; any where vh = n)
    lensq = vh[0] ** 2 + vh[1] ** 2
    t1 = np.array([-vh[1], vh[0], 0.0]) / np.sqrt(lensq) if lensq > 0.0 else np.array([1.0, 0, 0])
    t2 = np.cross(vh, t1)
    # 3. a point on the projected disc, the hidden half squeezed onto the visible one
    r = np.sqrt(u1)
    phi = 2.0 * np.pi * u2
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + vh[2])
    p2 = (1.0 - s) * np.sqrt(1.0 - p1 * p1) + s * p2
    # 4. back onto the hemisphere
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * vh
    # 5. unstretch: the normal of the ellipsoid
    m = np.stack([alpha_x * nh[:, 0], alpha_y * nh[:, 1], np.maximum(0.0, nh[:, 2])], -1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def vndf_pdf(v: np.ndarray, m: np.ndarray, alpha: float) -> np.ndarray:
    """D_v(m) = G1(v) (v.m)+ D(m) / (n.v), isotropic GGX (Heitz 2014, eq. 38): (M,)."""
    v = np.asarray(v, np.float64)
    NoV = float(v @ N)
    G1 = masking.G1_smith(masking.Lambda_GGX(NoV, alpha))
    return G1 * np.maximum(m @ v, 0.0) * D_GGX(N, m, alpha) / NoV


def reflect(v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """l = 2 (v.m) m - v: the mirror direction of v about each m, (M, 3)."""
    return 2.0 * (m @ v)[:, None] * m - v


# --- the albedo's three estimators -----------------------------------------------------------


def albedo_samples(
    method: str, v: np.ndarray, perceptual_roughness: float, count: int, seed: int = 0
) -> np.ndarray:
    """``count`` one-sample estimates of E(v) = int f_spec (n.l) dl, f_spec the standard
    GGX specular (height-correlated G2) with F = 1, drawn by ``method``: "vndf" (l the
    reflection about a visible normal, weight G2/G1(v)), "cosine" (p = n.l/pi, weight
    pi f_spec) or "uniform" (p = 1/(2 pi), weight 2 pi f_spec n.l). Seeded."""
    rng = np.random.default_rng(seed)
    r = max(perceptual_roughness, 0.045)
    alpha = r * r
    u1, u2 = rng.random(count), rng.random(count)
    v = np.asarray(v, np.float64)
    if method == "vndf":
        l = reflect(v, sample_vndf(v, alpha, alpha, u1, u2))
        NoL = l @ N
        NoV = float(v @ N)
        G1v = masking.G1_smith(masking.Lambda_GGX(NoV, alpha))
        with np.errstate(divide="ignore", invalid="ignore"):
            G2 = masking.G2_height_correlated(
                masking.Lambda_GGX(NoV, alpha), masking.Lambda_GGX(np.maximum(NoL, 1e-12), alpha)
            )
        return np.where(NoL > 0.0, G2 / G1v, 0.0)
    if method == "cosine":
        rad, phi = np.sqrt(u1), 2.0 * np.pi * u2
        l = np.stack([rad * np.cos(phi), rad * np.sin(phi), np.sqrt(1.0 - u1)], -1)
        return np.pi * f_spec_GGX(1.0, alpha, N, l, np.broadcast_to(v, l.shape))[:, 0]
    if method == "uniform":
        z = u1
        rad, phi = np.sqrt(1.0 - z * z), 2.0 * np.pi * u2
        l = np.stack([rad * np.cos(phi), rad * np.sin(phi), z], -1)
        f = f_spec_GGX(1.0, alpha, N, l, np.broadcast_to(v, l.shape))[:, 0]
        return 2.0 * np.pi * f * z
    raise ValueError(f"method must be 'vndf', 'cosine' or 'uniform', not {method!r}")


def view_at(theta_deg: float) -> np.ndarray:
    """The unit view direction at ``theta_deg`` from n, in the x-z plane."""
    t = np.radians(theta_deg)
    return np.array([np.sin(t), 0.0, np.cos(t)])
