"""Twin of glsl/brdf/diffraction.glsl: reflection from a periodic grating (RTR4 §9.11,
diffraction), and its spectral reference (docs/diffraction.md).

A surface whose height varies periodically with period d along one direction g in the
tangent plane (a compact disc: tracks of pitch d) sends a plane wave into discrete orders
m = 0, +-1, +-2, ...; with l and v the unit directions to the light and to the viewer,
each order obeys the grating equation in its vector form (conical diffraction included)

    l_t + v_t = (m lambda / d) g,      in the plane: sin(theta_m) = sin(theta_i) + m lambda/d,

l_t and v_t being the tangential components (Stam 1999, "Diffraction Shaders", SIGGRAPH,
eq. for u = l_t + v_t; Born & Wolf, "Principles of Optics", sec. 8.6.1). The equation is
symmetric in l and v, so the orders are reciprocal.

Model (this renderer's, stated): each order is the base's GGX lobe around the diffracted
direction instead of the mirror one, i.e. the microfacet lobe F D V with the half vector
replaced by the order's

    h_m = normalize(l + v - (m lambda / d) g),

which is the ordinary half vector for m = 0 and is the normal exactly where the grating
equation holds; the lobe's width is the surface roughness. Each order is weighted by the
efficiency of a thin sinusoidal phase grating of peak-to-valley depth D in scalar
(Kirchhoff) theory, Goodman, "Introduction to Fourier Optics", 3rd ed., sec. 4.4.3:

    eta_m = J_m(a)^2,   a = pi D (n.l + n.v) / lambda,

the phase of a profile (D/2) sin(2 pi x / d) seen on the way in and out. sum over all m of
J_m^2 = 1 (Bessel's identity), so the orders share the light the mirror lobe had; the
orders |m| > GRATING_ORDERS are left out (energy lost, measured in docs/diffraction.md).
a is symmetric in l and v, so the whole BRDF is reciprocal.

Colour: the sum over wavelengths against the CIE 1931 colour-matching functions, converted
to linear sRGB exactly as thin_film.spectrum_to_rgb does (reused, not copied); the
result is clamped at 0 (a single order's narrow band is outside the sRGB gamut).

* ``f_spec_grating`` with ``GRATING_WAVELENGTHS_NM`` / ``GRATING_WEIGHTS``: the GLSL's
  sampling, 16 bands of 25 nm, each sampled at its centre and weighted by the colour of
  its 5 nm CIE samples. Same order of operations as the GLSL.
* ``f_spec_grating`` with ``SPECTRAL_WAVELENGTHS_NM`` / ``SPECTRAL_WEIGHTS`` (every 5 nm
  sample of the CIE table) and more orders: the spectral reference.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from app.reference._vec import dot
from app.reference.thin_film import CIE_WAVELENGTHS_NM, spectrum_to_rgb

# Orders kept on each side (m = -GRATING_ORDERS..GRATING_ORDERS); the GLSL's.
GRATING_ORDERS = 3
# Terms of J_m's power series: enough for a <= 2 pi 300 / 380 (depth <= 300 nm), where
# the next term is below 1e-8 of the largest (docs/diffraction.md).
GRATING_BESSEL_TERMS = 12
# The depth limit of the scene format (nm): keeps a within the series' range.
GRATING_MAX_DEPTH_NM = 300.0

# --- wavelength sampling ----------------------------------------------------------------------
# The spectral reference: each 5 nm CIE sample, weighted by its colour (spectrum_to_rgb of a
# spectrum that is 1 at that sample alone); the weights sum to (1, 1, 1) exactly.
SPECTRAL_WAVELENGTHS_NM = CIE_WAVELENGTHS_NM
SPECTRAL_WEIGHTS = spectrum_to_rgb(np.eye(len(CIE_WAVELENGTHS_NM)))  # (81, 3)

# The GLSL's: 16 bands of 25 nm over 380-780 nm (the 780 nm sample joins the last band),
# each sampled at its centre with the summed weight of its CIE samples, so a flat
# spectrum still gives exactly white.
GRATING_SAMPLES = 16
_band = np.minimum(((CIE_WAVELENGTHS_NM - 380.0) // 25.0).astype(int), GRATING_SAMPLES - 1)
GRATING_WAVELENGTHS_NM = 380.0 + 25.0 * (np.arange(GRATING_SAMPLES) + 0.5)
GRATING_WEIGHTS = np.stack(
    [SPECTRAL_WEIGHTS[_band == j].sum(axis=0) for j in range(GRATING_SAMPLES)]
)  # (16, 3)


def bessel_J(m: int, x: np.ndarray, terms: int = GRATING_BESSEL_TERMS) -> np.ndarray:
    """J_m(x) for an integer m >= 0 by its power series, sum_k (-1)^k (x/2)^(2k+m) /
    (k! (k+m)!), cut at ``terms`` terms (the GLSL's loop)."""
    half = 0.5 * np.asarray(x, np.float64)
    term = np.ones_like(half)
    for i in range(1, m + 1):  # (x/2)^m / m!
        term = term * half / i
    q = -half * half
    total = term
    for k in range(1, terms):
        term = term * q / (k * (k + m))
        total = total + term
    return total


def grating_efficiency(m: int, depth_nm, wavelength_nm, NoL, NoV) -> np.ndarray:
    """eta_m = J_|m|(a)^2, a = pi D (n.l + n.v) / lambda (Goodman sec. 4.4.3)."""
    a = np.pi * np.asarray(depth_nm, np.float64) * (NoL + NoV) / wavelength_nm
    j = bessel_J(abs(m), a)
    return j * j


def grating_direction(n: np.ndarray, t: np.ndarray) -> np.ndarray:
    """g: the unit direction across the grooves. The grooves run along the material's
    tangent t, so g = n x t (t orthonormalised against n by the caller)."""
    return np.cross(n, t)


def shifted_direction(d: np.ndarray, n: np.ndarray, g: np.ndarray, shift) -> tuple:
    """(d', ok): d with its tangential part moved by -shift g and its normal part rebuilt
    (unit length, n.d' >= 0); ok is False where the moved part is >= 1 long (no such
    direction: an evanescent order). The map keeps the projected solid angle
    (n.d) d omega = dx dy of the direction cosines, Harvey et al. 1999's shift invariance."""
    d = np.asarray(d, np.float64)
    dt = d - n * dot(n, d)[..., None] - np.asarray(shift, np.float64)[..., None] * g
    c2 = 1.0 - dot(dt, dt)
    ok = c2 > 0.0
    return dt + n * np.sqrt(np.maximum(c2, 0.0))[..., None], ok


def order_direction(l: np.ndarray, n: np.ndarray, g: np.ndarray, shift: float) -> np.ndarray:
    """The direction into which order m sends the light from l (the grating equation:
    tangential part -l_t + shift g, unit length), NaN where the order is evanescent."""
    l = np.asarray(l, np.float64)
    lt = l - n * dot(n, l)[..., None]
    vt = -lt + shift * g
    c2 = 1.0 - dot(vt, vt)
    with np.errstate(invalid="ignore"):
        return vt + n * np.sqrt(np.where(c2 >= 0.0, c2, np.nan))[..., None]


def f_spec_grating(
    lobe: Callable[[np.ndarray, np.ndarray], np.ndarray],
    n: np.ndarray,
    g: np.ndarray,
    l: np.ndarray,
    v: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    period_nm: float,
    depth_nm: float,
    wavelengths: np.ndarray = GRATING_WAVELENGTHS_NM,
    weights: np.ndarray = GRATING_WEIGHTS,
    orders: int = GRATING_ORDERS,
) -> np.ndarray:
    """The grating's specular reflection, (..., 3):

        sum_lambda W(lambda) sum_{|m| <= orders} eta_m(lambda)
            (f(l, v'_m) + f(l'_m, v)) / 2,      shift s = m lambda / d,

    f = ``lobe(l, v)`` the material's microfacet lobe F D V (..., 3), x'_m = x with its
    tangential part moved by -s g (``shifted_direction``; a half is 0 where that direction
    does not exist). Each half peaks where l_t + v_t = s g (the grating equation); each
    integrates over v (cosine-weighted) to at most the lobe's albedo, because the shift keeps
    the projected solid angle; the two together make it reciprocal (f is). m = 0 is f(l, v)
    itself. Clamped at 0 as a whole. ``wavelengths``/``weights``: the GLSL's 16 bands or the
    spectral reference (module docstring)."""
    l = np.asarray(l, np.float64)
    v = np.asarray(v, np.float64)
    total = 0.0
    base = lobe(l, v)
    for lam, weight in zip(wavelengths, weights, strict=True):
        band = grating_efficiency(0, depth_nm, lam, NoL, NoV)[..., None] * base
        for m in range(-orders, orders + 1):
            if m == 0:
                continue
            shift = m * lam / period_nm
            vm, v_ok = shifted_direction(v, n, g, shift)
            lm, l_ok = shifted_direction(l, n, g, shift)
            half = np.where(v_ok[..., None], lobe(l, vm), 0.0)
            half = half + np.where(l_ok[..., None], lobe(lm, v), 0.0)
            eta = grating_efficiency(m, depth_nm, lam, NoL, NoV)
            band = band + (0.5 * eta)[..., None] * half
        total = total + weight * band
    return np.maximum(total, 0.0)
