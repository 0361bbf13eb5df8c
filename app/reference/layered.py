"""A float64 Monte-Carlo reference for a flat clear coat over a base (RTR4 §9.12),
independent of both clear-coat variants of glsl/brdf/clearcoat.glsl.

The layer is a slab of index ``eta`` (relative to the medium above) with a perfectly flat
top interface and a base BRDF at the bottom; light inside is absorbed by Beer-Lambert,
keeping T0^(1/cos) along a path at angle theta to the normal (T0: the transmittance at
normal incidence through the thickness, once). A random walk follows each path exactly:

1. At the top the exact dielectric Fresnel F(eta, cos) is reflected (a delta lobe: the
   coat's reflection, ``coat``), the rest refracts in by Snell's law.
2. Down through the coat (absorption), then the base scatters it: a new direction is drawn
   from a mixture of cosine-weighted and GGX-NDF sampling (one-sample MIS: the weight is
   f cos / (the mixture's pdf)), with the base BRDF of app/reference/material.py evaluated
   with the directions inside the coat. The base must be given with its Fresnel relative
   to the coat (resolve it with medium_ior = the coat's index).
3. Up through the coat, and at the top from inside: the fraction 1 - F(1/eta, cos) escapes
   (recorded, with its exit direction), the rest (all of it past the critical angle: total
   internal reflection) reflects back down, and the walk goes on at step 2.

Splitting instead of Russian roulette: every escape is recorded with its weight and the
walk continues with the reflected weight, for ``bounces`` base interactions; what is left
after the last one is reported as ``residual`` (a bound on the truncation error). The
generator is seeded: the same call gives the same numbers.

Conventions as app/reference: n = +Z, directions unit, last axis 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.common.models import Model, ModelParams
from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.fresnel import F_dielectric
from app.reference.material import (
    ShadingPoint,
    Surface,
    brdf_eval,
    clearcoat_factors,
    material_alpha,
)
from app.reference.ndf import D_GGX
from app.reference.quadrature import cosine_rule, direction, reflected_rule

N = np.array([0.0, 0.0, 1.0])


@dataclass
class LayeredAlbedo:
    """Directional albedo of the coated surface for one incidence direction, apart."""

    coat: float  # the flat top interface's reflection, F(eta, cos theta_i): exact
    substrate: np.ndarray  # (3,) everything that went through the coat and came back out
    stderr: np.ndarray  # (3,) one standard error of ``substrate``
    residual: np.ndarray  # (3,) weight still inside after the last bounce (not counted)
    exits: np.ndarray  # (M, 3) exit directions of the recorded escapes
    weights: np.ndarray  # (M, 3) their weights / paths (sum over M: ``substrate``)

    @property
    def total(self) -> np.ndarray:
        return self.coat + self.substrate


def _sample_cosine(rng: np.random.Generator, count: int) -> np.ndarray:
    u1, u2 = rng.random(count), rng.random(count)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], -1)


def _sample_ggx_reflection(rng: np.random.Generator, l: np.ndarray, alpha: float) -> np.ndarray:
    """v = reflect(l) about h drawn from D(h)(n.h) (Walter et al. 2007, eq. 35-36)."""
    u1, u2 = rng.random(len(l)), rng.random(len(l))
    tan2 = alpha * alpha * u1 / np.maximum(1.0 - u1, 1e-300)
    cos_t = 1.0 / np.sqrt(1.0 + tan2)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * np.pi * u2
    h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
    lh = np.sum(l * h, -1)
    return 2.0 * lh[:, None] * h - l


def _pdf_mixture(l: np.ndarray, v: np.ndarray, alpha: float, p_spec: float) -> np.ndarray:
    """The mixture's pdf of v (solid angle): (1 - p) cos/pi + p D(h)(n.h)/(4 v.h)."""
    cos_v = np.maximum(v[:, 2], 0.0)
    hv = l + v
    h = hv / np.maximum(np.linalg.norm(hv, axis=-1, keepdims=True), 1e-300)
    vh = np.maximum(np.sum(v * h, -1), 1e-300)
    spec = D_GGX(N, h, alpha) * np.maximum(h[:, 2], 0.0) / (4.0 * vh)
    return (1.0 - p_spec) * cos_v / np.pi + p_spec * spec


def random_walk(
    base: Surface,
    params: ModelParams,
    model: Model,
    eta: float,
    T0: np.ndarray | tuple[float, float, float],
    l_out: np.ndarray,
    paths: int = 200_000,
    bounces: int = 32,
    seed: int = 1,
    p_spec: float = 0.5,
) -> LayeredAlbedo:
    """The walk above for light arriving from the unit direction ``l_out`` (outside, towards
    the light); ``base`` (scalar fields), ``params``, ``model``: the base BRDF inside the coat
    (its clear coat ignored); ``eta`` > 1 the coat's index over the medium's."""
    rng = np.random.default_rng(seed)
    T0 = np.broadcast_to(np.asarray(T0, np.float64), 3)
    log_T0 = np.log(np.maximum(T0, 1e-300))
    base_model = Model(**{**model.__dict__, "clearcoat": "none"})
    alpha = float(material_alpha(base))
    cos_i = float(l_out[2])
    coat = float(F_dielectric(eta, cos_i))
    # Refracted in: the direction towards the light as seen inside the coat.
    sin_in = np.hypot(l_out[0], l_out[1]) / eta
    scale = sin_in / max(np.hypot(l_out[0], l_out[1]), 1e-300)
    l_in = np.array([l_out[0] * scale, l_out[1] * scale, np.sqrt(1.0 - sin_in * sin_in)])
    l = np.broadcast_to(l_in, (paths, 3)).copy()
    weight = np.full((paths, 3), 1.0 - coat)
    weight *= np.exp(log_T0 / l[:, 2:3])  # down
    exits, deposits = [], []
    per_path = np.zeros((paths, 3))  # each path's escaped weight, for the standard error
    for _ in range(bounces):
        pick = rng.random(paths) < p_spec
        v = np.where(
            pick[:, None], _sample_ggx_reflection(rng, l, alpha), _sample_cosine(rng, paths)
        )
        ok = v[:, 2] > 0.0
        v[~ok] = N  # placeholder; its weight is 0
        point = ShadingPoint(base, params, N, None, np.array([1.0, 0.0, 0.0]), v)
        f = brdf_eval(point, base_model, l)
        pdf = _pdf_mixture(l, v, alpha, p_spec)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where((ok & (pdf > 0.0))[:, None], f * (v[:, 2] / pdf)[:, None], 0.0)
        weight = weight * g
        weight *= np.exp(log_T0 / np.maximum(v[:, 2:3], 1e-300))  # up
        F_in = F_dielectric(1.0 / eta, v[:, 2])
        out = weight * (1.0 - F_in)[:, None]
        # Snell out: sin_o = eta sin_in, same azimuth.
        s_in = np.hypot(v[:, 0], v[:, 1])
        s_out = np.minimum(eta * s_in, 1.0)
        k = np.where(s_in > 0.0, s_out / np.maximum(s_in, 1e-300), 0.0)
        d_out = np.stack([v[:, 0] * k, v[:, 1] * k, np.sqrt(1.0 - s_out * s_out)], -1)
        per_path += out
        escaping = out.max(axis=-1) > 0.0
        exits.append(d_out[escaping])
        deposits.append(out[escaping])
        weight = weight * F_in[:, None]
        # Reflected down at the top: towards-the-light direction for the base is v mirrored.
        l = np.stack([-v[:, 0], -v[:, 1], v[:, 2]], -1)
        weight *= np.exp(log_T0 / np.maximum(l[:, 2:3], 1e-300))  # down again
    return LayeredAlbedo(
        coat=coat,
        substrate=per_path.mean(axis=0),
        stderr=per_path.std(axis=0) / np.sqrt(paths),
        residual=weight.sum(axis=0) / paths,
        exits=np.concatenate(exits),
        weights=np.concatenate(deposits) / paths,
    )


def coated_albedo(
    s: Surface, params: ModelParams, model: Model, theta_deg: float
) -> tuple[float, np.ndarray]:
    """(coat, substrate) directional albedo of a coated material's float64 twin at
    incidence ``theta_deg``, by deterministic quadrature in three pieces with a rule each:
    the coat's lobe (a rule on its roughness), the base's specular lobe under the coat (on
    the base's roughness, widened by eta for the refracted compositions) and the diffuse
    lobe with the inter-reflection series (a cosine rule)."""
    l = direction(theta_deg, 30.0)
    rc = max(float(params.clearcoat_roughness), MIN_PERCEPTUAL_ROUGHNESS)

    def parts(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        point = ShadingPoint(s, params, N, N, np.array([1.0, 0.0, 0.0]), v)
        b = clearcoat_factors(point, model, np.broadcast_to(l, v.shape))
        return np.asarray(b.f_coat, np.float64), b.f_spec, b.f_diffuse

    def integral(f: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        return np.sum(f * (np.maximum(v @ N, 0.0) * w).reshape(-1, *[1] * (f.ndim - 1)), axis=0)

    v, w = reflected_rule(l, rc * rc, 48, 32)
    coat = float(integral(parts(v)[0], v, w))
    widen = float(params.clearcoat_eta) if model.clearcoat.startswith("weidlich") else 1.0
    v, w = reflected_rule(l, max(float(material_alpha(s)), 0.002) * widen, 48, 32)
    spec = integral(parts(v)[1], v, w)
    v, w = cosine_rule(48, 64)
    return coat, spec + integral(parts(v)[2], v, w)
