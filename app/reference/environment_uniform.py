"""Twin of glsl/lights/environment_uniform.glsl: a uniform environment integrated exactly per
point (docs/ibl.md, "The uniform environment").

``L_o(v) = L R(v)`` with the directional albedo ``R(v) = integral f(l, v) (n.l)+ dl``
(RTR4 §9.3) of the whole BRDF twin (``brdf_eval``, every model), by a fixed deterministic
quadrature in each point's shading frame: one Hammersley set for every point, mapped
through GGX visible-normal sampling (Heitz 2018, "Sampling the GGX Distribution of
Visible Normals") with the point's alpha_x, alpha_y, cosine sampling, and, with a clear
coat, the coat's visible normals about its normal, combined by the balance heuristic
(Veach 1997, "Robust Monte Carlo Methods for Light Transport Simulation", §9.2):
``R ~ sum_k sum_j g(l_kj) / (m sum_k' pdf_k'(l_kj))``, ``g = f (n.l)+``, m points per
strategy. Every function keeps the GLSL's name and order of operations; the GPU differs by
float32 rounding only. Also the float64 ray-caster's way to light a uniform environment
(app/frame/raycast.py).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from app.common.models import BRDF_TERMS, TERM_SPECULAR, Model, ModelParams
from app.reference._vec import dot, normalize
from app.reference.constants import MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS, PI
from app.reference.material import (
    ShadingPoint,
    Surface,
    brdf_eval,
    brdf_factors,
    material_alpha,
    orthonormal_tangent,
    selected_terms,
    surface_reflection,
)
from app.reference.quadrature import reflected_rule


def hammersley(i: int, m: int) -> tuple[float, float]:
    """Hammersley point i of m: ((i + 1/2) / m, the base-2 radical inverse of i's 32 bits)."""
    b = int(f"{i & 0xFFFFFFFF:032b}"[::-1], 2)
    return (i + 0.5) / m, b * 2.0**-32


def sample_ggx_vndf(
    v: np.ndarray, alpha_x: np.ndarray, alpha_y: np.ndarray, u: tuple
) -> np.ndarray:
    """A GGX visible normal for local views v (..., 3), z along n (Heitz 2018, listing 1)."""
    ax = np.asarray(alpha_x, np.float64)
    ay = np.asarray(alpha_y, np.float64)
    vh = normalize(np.stack([ax * v[..., 0], ay * v[..., 1], v[..., 2]], axis=-1))
    len2 = vh[..., 0] ** 2 + vh[..., 1] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(len2 > 0.0, 1.0 / np.sqrt(len2), 0.0)
    T1 = np.where(
        (len2 > 0.0)[..., None],
        np.stack([-vh[..., 1] * inv, vh[..., 0] * inv, np.zeros_like(inv)], axis=-1),
        np.array([1.0, 0.0, 0.0]),
    )
    T2 = np.cross(vh, T1)
    r = np.sqrt(u[0])
    phi = 2.0 * PI * u[1]
    t1 = r * np.cos(phi)
    t2 = r * np.sin(phi)
    w = 0.5 * (1.0 + vh[..., 2])
    t2 = (1.0 - w) * np.sqrt(max(1.0 - t1 * t1, 0.0)) + w * t2
    nz = np.sqrt(np.maximum(1.0 - t1 * t1 - t2 * t2, 0.0))
    nh = t1 * T1 + t2[..., None] * T2 + nz[..., None] * vh
    return normalize(
        np.stack([ax * nh[..., 0], ay * nh[..., 1], np.maximum(nh[..., 2], 0.0)], axis=-1)
    )


def ggx_vndf_pdf(
    v: np.ndarray, l: np.ndarray, alpha_x: np.ndarray, alpha_y: np.ndarray
) -> np.ndarray:
    """Density over l of reflecting v about a GGX visible normal: D(h) G1(v) / (4 v.z)
    (Heitz 2018, eq. 17 and the reflection's Jacobian 1/(4 v.h)); 0 where h.z <= 0."""
    h = normalize(v + l)
    ax = np.asarray(alpha_x, np.float64)
    ay = np.asarray(alpha_y, np.float64)
    hs = np.stack([h[..., 0] / ax, h[..., 1] / ay, h[..., 2]], axis=-1)
    q = dot(hs, hs)
    D = 1.0 / (PI * ax * ay * q * q)
    s2 = (ax * ax * v[..., 0] ** 2 + ay * ay * v[..., 1] ** 2) / (v[..., 2] ** 2)
    lam = 0.5 * (np.sqrt(1.0 + s2) - 1.0)
    return np.where(h[..., 2] > 0.0, D / (4.0 * (1.0 + lam) * v[..., 2]), 0.0)


def cosine_phase(m: int) -> float:
    """The cosine directions' azimuth offset for m points: half the finest azimuth step of
    their radical inverses (1/2^ceil(log2 m)), so that no point lies in the plane of v and
    its mirror direction, where an isotropic frame puts a narrow lobe's peak; a point there
    would add ~1/m of the lobe (measured: +4.6 % at 15-20 degrees for a mirror)."""
    return 0.5 / 2.0 ** math.ceil(math.log2(m))


def sample_cosine(u: tuple, phase: float) -> np.ndarray:
    """A cosine-weighted direction about z (Malley's method), density z / pi, its azimuth
    turned by 2 pi ``phase``."""
    r = np.sqrt(u[0])
    phi = 2.0 * PI * (u[1] + phase)
    return np.array([r * np.cos(phi), r * np.sin(phi), np.sqrt(max(1.0 - u[0], 0.0))])


def environment_frame(
    n: np.ndarray, t: np.ndarray, v: np.ndarray, anisotropic: np.ndarray
) -> np.ndarray:
    """(..., 3, 3) frames whose columns are x, y, z = n: x along the BRDF's tangent where
    anisotropic, else along v's projection on the surface."""
    x = orthonormal_tangent(n, np.where(np.asarray(anisotropic)[..., None], t, v))
    return np.stack([x, np.cross(n, x), n], axis=-1)


def _to_world(frame: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", frame, d)


def _to_local(frame: np.ndarray, d: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...i->...j", frame, d)


def environment_local_view(frame: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v in the frame, lifted to at least MIN_N_DOT_V above the horizon."""
    local = _to_local(frame, v)
    local[..., 2] = np.maximum(local[..., 2], MIN_N_DOT_V)
    return normalize(local)


def environment_integrand(
    point: ShadingPoint, model: Model, l: np.ndarray, terms: str = "all"
) -> tuple[np.ndarray, np.ndarray]:
    """g(l) = f(l, v) (n.l)+ at the point as the lights take it (``brdf_eval``, or with a
    coat normal of its own, ``point.nc`` not None, ``brdf_eval_layered_cos``'s cosine per
    layer), apart: (the subsurface lobe's part, the surface reflection's part), each
    (..., 3); their sum is ``brdf_eval`` (n.l)+ (RTR4 §9.1's two reflections, the terms
    ``terms`` keeps)."""
    n = np.asarray(point.n, np.float64)
    l = np.asarray(l, np.float64)
    NoL = dot(n, l)
    b = brdf_factors(point, model, l)
    if point.nc is not None and model.clearcoat != "none":
        NoLc = dot(np.asarray(point.nc, np.float64), l)
        base_d = selected_terms(b.f_diffuse, 0.0 * b.f_spec, terms)
        base_s = selected_terms(0.0 * b.f_diffuse, b.f_spec, terms)
        coat = np.asarray(b.f_coat, np.float64) if BRDF_TERMS[terms] & TERM_SPECULAR else 0.0
        lit = (NoL > 0.0)[..., None]
        d = np.where(lit, base_d * NoL[..., None], 0.0)
        surface = np.where(lit, base_s * NoL[..., None], 0.0)
        return d, surface + np.where(NoLc > 0.0, coat * NoLc, 0.0)[..., None]
    lit = (NoL > 0.0)[..., None]
    d = selected_terms(b.f_diffuse, 0.0 * b.f_spec, terms)
    surface = selected_terms(0.0 * b.f_diffuse, surface_reflection(b), terms)
    return np.where(lit, d * NoL[..., None], 0.0), np.where(lit, surface * NoL[..., None], 0.0)


def uniform_environment_albedo(
    point: ShadingPoint, model: Model, count: int, terms: str = "all"
) -> np.ndarray:
    """R(v) (..., 3) of the BRDF at the point's unit n, v (..., 3) by ``count`` directions
    in all (count // strategies per strategy). ``point.nc``: the coat's own normal (None:
    n). The subsurface lobe is integrated by the cosine directions alone (exact for
    Lambert), the surface reflection by every strategy with the balance heuristic
    (docs/ibl.md)."""
    s, p, nc = point.s, point.params, point.nc
    n = np.asarray(point.n, np.float64)
    v = np.asarray(point.v, np.float64)
    t = np.broadcast_to(np.asarray(point.t, np.float64), n.shape)
    point = replace(point, n=n, t=t, v=v)
    aniso_amount = np.broadcast_to(np.asarray(s.anisotropy, np.float64), n.shape[:-1])
    anisotropic = model.anisotropic & (aniso_amount != 0.0)
    alpha = np.broadcast_to(material_alpha(s), n.shape[:-1])
    alpha_min = MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS
    alpha_x = np.where(anisotropic, np.maximum(alpha * (1.0 + aniso_amount), alpha_min), alpha)
    alpha_y = np.where(anisotropic, np.maximum(alpha * (1.0 - aniso_amount), alpha_min), alpha)
    frame = environment_frame(n, t, v, anisotropic)
    v_local = environment_local_view(frame, v)
    coat = model.clearcoat != "none" and p.clearcoat > 0.0
    strategies = 3 if coat else 2
    if coat:
        n_coat = n if nc is None else np.broadcast_to(np.asarray(nc, np.float64), n.shape)
        rc = max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS)
        alpha_c = rc * rc
        frame_c = environment_frame(n_coat, t, v, np.zeros(n.shape[:-1], bool))
        v_coat = environment_local_view(frame_c, v)
    m = max(count // strategies, 1)
    phase = cosine_phase(m)
    total = np.zeros(n.shape)
    for i in range(m):
        u = hammersley(i, m)
        for k in range(strategies):
            if k == 0:
                h = sample_ggx_vndf(v_local, alpha_x, alpha_y, u)
                l = _to_world(frame, 2.0 * dot(v_local, h)[..., None] * h - v_local)
            elif k == 1:
                l = _to_world(frame, np.broadcast_to(sample_cosine(u, phase), n.shape))
            else:
                h = sample_ggx_vndf(v_coat, alpha_c, alpha_c, u)
                l = _to_world(frame_c, 2.0 * dot(v_coat, h)[..., None] * h - v_coat)
            d, surface = environment_integrand(point, model, l, terms)
            l_local = _to_local(frame, l)
            pdf_cos = np.maximum(l_local[..., 2], 0.0) / PI
            pdf = ggx_vndf_pdf(v_local, l_local, alpha_x, alpha_y) + pdf_cos
            if coat:
                pdf = pdf + ggx_vndf_pdf(v_coat, _to_local(frame_c, l), alpha_c, alpha_c)
            lit = np.max(surface, axis=-1) > 0.0
            with np.errstate(divide="ignore", invalid="ignore"):
                total += np.where(lit[..., None], surface / (m * pdf)[..., None], 0.0)
                if k == 1:  # the subsurface lobe: the cosine strategy alone
                    total += d / (m * pdf_cos)[..., None]
    return total


def converged_albedo(s: Surface, p: ModelParams, model: Model, v: np.ndarray) -> np.ndarray:
    """R(v) (k, 3) at the views v (k, 3) about n = +Z (tangent +Y) by the dense deterministic
    rule of app/reference/quadrature.py (``reflected_rule``: GGX-shaped nodes about the
    mirror direction at the narrowest lobe's alpha, Gauss-Legendre panels graded towards
    the horizon, ~7e4 nodes; doubling them moved R by < 1e-6 where checked): the value the
    quadrature above is measured against (docs/ibl.md)."""
    alpha = max(float(np.max(s.perceptual_roughness)), MIN_PERCEPTUAL_ROUGHNESS) ** 2
    if model.clearcoat != "none":
        alpha = min(alpha, max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS) ** 2)
    out = []
    for view in np.asarray(v, np.float64):
        l, w = reflected_rule(view, alpha, 48, 48)
        k = len(l)
        n = np.broadcast_to([0.0, 0.0, 1.0], (k, 3))
        t = np.broadcast_to([0.0, 1.0, 0.0], (k, 3))
        f = brdf_eval(ShadingPoint(s, p, n, None, t, np.broadcast_to(view, (k, 3))), model, l)
        out.append(np.sum(f * (np.maximum(l[:, 2], 0.0) * w)[:, None], axis=0))
    return np.array(out)


def uniform_environment_radiance(
    radiance: np.ndarray, point: ShadingPoint, model: Model, count: int, terms: str = "all"
) -> np.ndarray:
    """L R(v): the uniform environment's light reflected towards the point's v."""
    albedo = uniform_environment_albedo(point, model, count, terms)
    return np.asarray(radiance, np.float64) * albedo
