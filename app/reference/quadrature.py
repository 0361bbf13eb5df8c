"""Deterministic hemisphere quadrature for the float64 twins (no Monte Carlo noise).

Used by the physics tests and by the tables the project computes itself (the Kulla-Conty
multiple-scattering tables). Conventions as in app/reference: n = +Z, vectors have a last
axis of 3, alpha = roughness^2.

GGX lobes get as narrow as alpha ~ 0.002, far too narrow for a plain rule in cos(theta);
the rules below substitute tan(theta) = s tan(psi) (with s = alpha this turns
D(m)(n.m) dm into sin(psi) cos(psi)/pi dpsi dphi for GGX) and cut the domain exactly where
a clamp such as (v.m)+ or (n.v)+ would put a kink.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

N = np.array([0.0, 0.0, 1.0])

# A limit on tan(theta) along each azimuth: phi (array) -> tan(theta_max) (inf: no limit).
TanLimit = Callable[[np.ndarray], np.ndarray]


def gauss_legendre(a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the n-point Gauss-Legendre rule on [a, b] (exact to degree 2n-1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w


def direction(theta_deg: float, phi_deg: float = 0.0) -> np.ndarray:
    """Unit vector at polar angle theta (from n = +Z) and azimuth phi, both in degrees."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def cosine_rule(n_mu: int, n_phi: int) -> tuple[np.ndarray, np.ndarray]:
    """Plain hemisphere rule: Gauss-Legendre in mu = cos(theta) on [0, 1] x uniform phi.

    Returns directions (N, 3) and weights (N,) with sum(w f(d)) ~ integral of f over the
    hemisphere (d omega = d mu d phi). Exact for polynomials in mu of degree < 2 n_mu times
    trigonometric polynomials in phi of degree < n_phi; the rule for smooth, broad lobes.
    """
    mu, w_mu = gauss_legendre(0.0, 1.0, n_mu)
    phi = (np.arange(n_phi) + 0.5) * (2.0 * np.pi / n_phi)
    st = np.sqrt(1.0 - mu * mu)[:, None]
    d = np.stack(
        [st * np.cos(phi), st * np.sin(phi), np.broadcast_to(mu[:, None], (n_mu, n_phi))], axis=-1
    )
    w = w_mu[:, None] * np.full(n_phi, 2.0 * np.pi / n_phi)
    return d.reshape(-1, 3), w.reshape(-1)


def tan_rule(
    scale: float,
    n_psi: int,
    n_phi: int,
    *,
    tan_limit: TanLimit | None = None,
    azimuth: float = 0.0,
    panels: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Hemisphere rule for lobes peaked at n: tan(theta) = scale tan(psi), psi in [0, psi_max].

    Returns directions (N, 3) and weights (N,) with sum(w f(d)) ~ integral of f over
    {d : n.d > 0, tan(theta_d) < tan_limit(phi_d)} (the whole hemisphere by default).

    * theta: with scale = alpha the GGX NDF's own shape is undone (D(m)(n.m) d omega becomes
      sin(psi)cos(psi)/pi dpsi dphi), so the nodes crowd into the peak however narrow it is;
      any scale within a few times alpha still converges fast (test_ggx_ndf_is_normalised).
    * psi: composite Gauss-Legendre (n_psi points per panel) on ``panels`` panels graded
      geometrically (edges 0, 3/4, 15/16, ... of psi_max) toward the cut psi_max(phi): near
      a horizon cut n.v and the height-correlated V change within a psi-width ~ alpha^2.
    * phi: Gauss-Legendre (n_phi points) on each quarter turn from ``azimuth``: the cuts of
      the callers change fastest near the quarter-turn points of the reference direction.
    """
    x, wx = np.polynomial.legendre.leggauss(n_phi)
    phi = np.concatenate([azimuth - np.pi + (x + 1.0 + 2.0 * k) * (np.pi / 4) for k in range(4)])
    w_phi = np.tile(wx * (np.pi / 4), 4)

    psi_max = np.full(phi.shape, np.pi / 2)
    if tan_limit is not None:
        psi_max = np.arctan(tan_limit(phi) / scale)

    edges = 1.0 - 4.0 ** -np.arange(panels, dtype=np.float64)
    edges = np.concatenate([[0.0], edges[1:], [1.0]])
    x, wx = np.polynomial.legendre.leggauss(n_psi)
    lo, hi = edges[:-1, None], edges[1:, None]
    u = (0.5 * (hi - lo) * (x + 1.0) + lo).ravel()
    w_u = (0.5 * (hi - lo) * wx).ravel()
    psi = psi_max[:, None] * u
    w_psi = psi_max[:, None] * w_u

    s, c = np.sin(psi), np.cos(psi)
    r2 = c * c + scale * scale * s * s
    r = np.sqrt(r2)
    cos_t, sin_t = c / r, scale * s / r  # theta = atan(scale tan psi), stable up to pi/2
    dtheta_dpsi = scale / r2
    w = sin_t * dtheta_dpsi * w_psi * w_phi[:, None]
    d = np.stack([sin_t * np.cos(phi)[:, None], sin_t * np.sin(phi)[:, None], cos_t], axis=-1)
    return d.reshape(-1, 3), w.reshape(-1)


def facing_limit(v: np.ndarray) -> TanLimit:
    """tan(theta_m) limit of {m : m.v > 0} along each azimuth (the domain of (v.m)+).

    m.v = sin(theta_m) sin(theta_v) cos(phi - phi_v) + cos(theta_m) cos(theta_v) > 0 is
    tan(theta_m) < cos(theta_v)/k with k = -sin(theta_v) cos(phi - phi_v), when k > 0.
    """
    sv, cv, phi_v = np.hypot(v[0], v[1]), v[2], np.arctan2(v[1], v[0])

    def limit(phi: np.ndarray) -> np.ndarray:
        k = -sv * np.cos(phi - phi_v)
        return np.where(k > 0.0, cv / np.where(k > 0.0, k, 1.0), np.inf)

    return limit


def reflection_limit(l: np.ndarray) -> TanLimit:
    """tan(theta_h) limit of {h : n.v > 0} for v = 2(l.h)h - l, the mirror of l about h.

    n.v = 2(l.h)(n.h) - n.l; divided by cos^2(theta_h) it is the quadratic
    -cos(theta_l) t^2 + 2 k t + cos(theta_l) in t = tan(theta_h), k = sin(theta_l) cos(phi - phi_l),
    positive below its root t = (k + sqrt(k^2 + cos^2(theta_l)))/cos(theta_l).
    """
    sl, cl, phi_l = np.hypot(l[0], l[1]), l[2], np.arctan2(l[1], l[0])

    def limit(phi: np.ndarray) -> np.ndarray:
        k = sl * np.cos(phi - phi_l)
        return (k + np.sqrt(k * k + cl * cl)) / cl

    return limit


def reflected_rule(
    l: np.ndarray, scale: float, n_psi: int, n_phi: int
) -> tuple[np.ndarray, np.ndarray]:
    """Rule over outgoing directions v (n.v > 0) built on half vectors h, for specular lobes.

    Samples h with ``tan_rule`` (scale = alpha puts the nodes in the specular peak), cut
    where the mirror direction v = 2(l.h)h - l reaches the horizon, and maps it to v with
    the Jacobian d omega_v = 4 (v.h) d omega_h (Walter et al. 2007, eq. 14). Each v in the upper
    hemisphere has exactly one such h (h = normalize(l + v), n.h > 0, l.h > 0), so
    sum(w f(v)) ~ integral of f over the upper hemisphere of v.
    """
    h, w_h = tan_rule(
        scale, n_psi, n_phi, tan_limit=reflection_limit(l), azimuth=np.arctan2(l[1], l[0])
    )
    lh = h @ l
    v = 2.0 * lh[:, None] * h - l
    return v, 4.0 * lh * w_h


def directional_albedo(f: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """R(l) = integral of f(l, v) (n.v)+ dv from BRDF values f (N, 3) at the rule's nodes v."""
    return np.sum(f * (np.maximum(v @ N, 0.0) * w)[:, None], axis=0)
