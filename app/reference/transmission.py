"""Twin of glsl/brdf/transmission.glsl: the transmitted term of a dielectric surface (RTR4
§14.5; glTF KHR_materials_transmission and KHR_materials_volume), float64, same names.

    L_t = transmission (1 - metallic) (1 - F(n.v)) base_color T(d) L_behind

F is the dielectric base's Schlick Fresnel, T(d) = exp(-sigma d) with sigma =
-ln(attenuation_color) / attenuation_distance (Beer-Lambert), and L_behind the opaque
image where the ray leaving the volume (``transmission_ray``: refracted in and out of a
sphere) meets the opaque surfaces, read at the mip level
``transmission_lod`` (the glTF Sample Viewer's and Filament's screen-space approximation
of rough refraction, which Walter et al. 2007, "Microfacet Models for Refraction through
Rough Surfaces", derive exactly). The exact refraction through an analytic sphere, which
measures this approximation, is app/reference/raycast.py's (docs/transmission.md).
"""

from __future__ import annotations

import numpy as np

from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.fresnel import F_schlick
from app.reference.masking import V_height_correlated_GGX
from app.reference.ndf import D_GGX


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(np.asarray(a, np.float64) * np.asarray(b, np.float64), axis=-1)


def refracted_direction(v: np.ndarray, n: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Snell's law for the view ray -v entering relative index ``eta`` (n2 / n1) through
    the unit normal ``n`` (GLSL refract()'s formula); total internal reflection gives the
    mirrored ray. ``v``, ``n`` (..., 3) unit; ``eta`` (...)."""
    v = np.asarray(v, np.float64)
    n = np.asarray(n, np.float64)
    cos_i = _dot(n, v)[..., None]
    inv = 1.0 / np.asarray(eta, np.float64)[..., None]
    k = 1.0 - inv * inv * (1.0 - cos_i * cos_i)
    refracted = -inv * v - (np.sqrt(np.maximum(k, 0.0)) - inv * cos_i) * n
    mirrored = -v + 2.0 * cos_i * n
    return np.where(k < 0.0, mirrored, refracted)


def transmission_ray(
    p: np.ndarray, v: np.ndarray, n: np.ndarray, eta: np.ndarray, thickness: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A volume's light path as through a solid sphere of diameter ``thickness`` (world
    units) touching the surface at ``p`` (Filament's "solid" refraction): refracted in at
    ``p`` by ``eta``, along the chord of length thickness cos(theta_t) to the far side,
    whose outward normal is n - 2 (n.t) t, refracted out there by 1 / eta. Returns the exit
    point and the outgoing unit direction (..., 3); ``p`` and -v for a thin-walled surface
    (thickness 0). A ball beyond its focal length is thus seen inverted."""
    p = np.asarray(p, np.float64)
    v = np.asarray(v, np.float64)
    n = np.asarray(n, np.float64)
    eta = np.asarray(eta, np.float64)
    thick = np.broadcast_to(np.asarray(thickness, np.float64), eta.shape)[..., None]
    t = refracted_direction(v, n, eta)
    NoT = _dot(n, t)[..., None]
    exit_point = p + t * (thick * np.maximum(-NoT, 0.0))
    n_back = n - 2.0 * NoT * t
    out = refracted_direction(-t, -n_back, 1.0 / eta)
    thin = thick <= 0.0
    return np.where(thin, p, exit_point), np.where(thin, -v, out)


# The three channels' wavelengths (nm) for KHR_materials_dispersion's index.
CHANNEL_WAVELENGTHS = np.array([630.0, 532.0, 465.0])


def dispersion_iors(ior: float, dispersion: float) -> np.ndarray:
    """KHR_materials_dispersion: (3,) indices at ``CHANNEL_WAVELENGTHS``,
    max(ior + (ior - 1) dispersion / 20 (523655 / lambda^2 - 1.5168), 1)."""
    spread = 523655.0 / CHANNEL_WAVELENGTHS**2 - 1.5168
    return np.maximum(ior + (ior - 1.0) * dispersion / 20.0 * spread, 1.0)


def beer_lambert(
    attenuation_color: np.ndarray, attenuation_distance: np.ndarray, d: np.ndarray
) -> np.ndarray:
    """Beer-Lambert transmittance exp(-sigma d), sigma = -ln(c) / attenuation_distance,
    over a path of length ``d``; 1 where attenuation_distance <= 0 (no attenuation).
    ``attenuation_color`` (..., 3); returns (..., 3)."""
    c = np.maximum(np.asarray(attenuation_color, np.float64), 1e-30)
    dist = np.asarray(attenuation_distance, np.float64)[..., None]
    d = np.asarray(d, np.float64)[..., None]
    safe = np.where(dist > 0.0, dist, 1.0)
    sigma = -np.log(c) / safe
    return np.where(dist > 0.0, np.exp(-sigma * d), 1.0)


def transmission_lod(
    perceptual_roughness: np.ndarray,
    eta: np.ndarray,
    thin: np.ndarray | bool,
    path: np.ndarray,
    depth_behind: np.ndarray,
    focal_px: float,
) -> np.ndarray:
    """The mip level of the opaque image: log2 of the rough lobe's footprint diameter in
    pixels on what lies behind, 2 path tan(spread) focal_px / depth_behind (at least one
    pixel), spread = 2 atan(alpha) for a thin wall (the mirrored reflection lobe),
    atan(alpha) (1 - 1/eta) through a volume's refraction (glsl/brdf/transmission.glsl)."""
    r = np.asarray(perceptual_roughness, np.float64)
    tilt = np.arctan(r * r)
    bend = np.maximum(1.0 - 1.0 / np.asarray(eta, np.float64), 0.0)
    spread = np.where(thin, 2.0 * tilt, tilt * bend)
    pixels = (
        2.0 * np.asarray(path, np.float64) * np.tan(np.minimum(spread, 1.5)) * focal_px
        / np.maximum(np.asarray(depth_behind, np.float64), 1e-6)
    )  # fmt: skip
    return np.log2(np.maximum(pixels, 1.0))


def transmission_weight(
    f0_dielectric: np.ndarray, NoV: np.ndarray, transmission: np.ndarray, metallic: np.ndarray
) -> np.ndarray:
    """transmission (1 - metallic) (1 - F_schlick(F0, n.v)) per channel; ``f0_dielectric``
    (..., 3)."""
    scale = np.asarray(transmission, np.float64) * (1.0 - np.asarray(metallic, np.float64))
    return scale[..., None] * (1.0 - F_schlick(f0_dielectric, NoV))


def transmitted_radiance(
    behind: np.ndarray, base_color: np.ndarray, weight: np.ndarray, transmittance: np.ndarray
) -> np.ndarray:
    """L_t = weight base_color transmittance L_behind (all (..., 3))."""
    return (
        np.asarray(weight, np.float64)
        * np.asarray(base_color, np.float64)
        * np.asarray(transmittance, np.float64)
        * np.asarray(behind, np.float64)
    )


# --- punctual lights seen through the surface ---


def transmission_alpha(alpha: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """The transmitted lobe's roughness: alpha clamp(2 eta - 2, 0, 1), floored at
    MIN_PERCEPTUAL_ROUGHNESS^2."""
    scale = np.clip(2.0 * np.asarray(eta, np.float64) - 2.0, 0.0, 1.0)
    return np.maximum(np.asarray(alpha, np.float64) * scale, MIN_PERCEPTUAL_ROUGHNESS**2)


def transmitted_light(
    n: np.ndarray,
    v: np.ndarray,
    l: np.ndarray,
    alpha_t: np.ndarray,
    f0_dielectric: np.ndarray,
    transmission: np.ndarray,
    metallic: np.ndarray,
) -> np.ndarray:
    """transmission (1 - metallic) (1 - F(v.h')) D(h') V(n.l', n.v) n.l' of a light behind
    a thin surface (KHR_materials_transmission's specular BTDF about the mirrored light
    l' = l - 2 (n.l) n, h' = |l' + v|); 0 for a light in front. ``n``, ``v``, ``l``
    (..., 3) unit; returns (..., 3)."""
    n = np.asarray(n, np.float64)
    v = np.asarray(v, np.float64)
    NoL = -_dot(n, l)
    behind = NoL > 0.0
    l_mirror = np.asarray(l, np.float64) + 2.0 * NoL[..., None] * n
    h = l_mirror + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    NoV = np.maximum(_dot(n, v), 0.0)
    cos = np.maximum(NoL, 0.0)
    lobe = D_GGX(n, h, alpha_t) * V_height_correlated_GGX(cos, NoV, alpha_t) * cos
    VoH = np.clip(_dot(v, h), 0.0, 1.0)
    weight = transmission_weight(f0_dielectric, VoH, transmission, metallic)
    return np.where(behind[..., None], weight * lobe[..., None], 0.0)
