"""Twin of glsl/brdf/thin_film.glsl: thin-film interference (RTR4 §9.11), and its spectral
reference.

A dielectric film of index n2 and thickness d lies between the medium the light arrives
from (n1) and a base (n3, complex for a metal). Light reflected at the top of the film and
light that went down, reflected at the base (once, twice, ...) and came back up interfere;
their phase difference 2 pi OPD / lambda, OPD = 2 n2 d cos(theta2), depends on the
wavelength, so a white light comes back coloured (soap bubbles, oil on water, the blue
anti-reflection coat of a lens). The amplitude is Airy's sum of the multiple reflections
(Born & Wolf, "Principles of Optics", sec. 7.6.1):

    r = (r12 + r23 e^(i delta)) / (1 + r12 r23 e^(i delta)),   delta = 2 pi OPD / lambda,

for each polarisation; R = |r|^2, averaged over s and p for unpolarised light.

Two evaluations live here:

* ``F_thin_film``: Belcour and Barla 2017, "A Practical Extension to Microfacet Theory for
  the Modeling of Varying Iridescence" (ACM TOG 36(4)), the GLSL's model. R(delta) is a
  Fourier series in delta (``C0 + 2 sum_m C_m cos(m (delta + phi))``) whose every term
  integrates against the colour-matching functions in closed form once those are fitted by
  Gaussians in wavenumber (their fits); the series is cut at ``FILM_TERMS`` terms. Same
  order of operations as the GLSL.
* ``F_thin_film_spectral``: the reference. Airy's exact reflectance per wavelength, 380 to
  780 nm in 5 nm steps, summed against the CIE 1931 2-degree colour-matching functions
  tabulated below and turned into linear sRGB; no fit, no truncation.

Colour convention of both (docs/thin-film.md): the spectrum is weighted by the bare
colour-matching functions (an equal-energy illuminant), converted to XYZ -> linear sRGB
(primaries and D65 white of IEC 61966-2-1), and each channel divided by what a flat
spectrum of 1 gives, so that a film that reflects every wavelength equally has F = (R, R,
R). Belcour and Barla's fits are of the bare functions, so the two evaluations differ only
by the fit and the truncation, which is what docs/thin-film.md measures.
"""

from __future__ import annotations

import numpy as np

# --- the CIE 1931 2-degree standard observer --------------------------------------------------
# x-bar, y-bar, z-bar at 5 nm from 380 to 780 nm: the CIE's published table (CIE 015:2004
# "Colorimetry", 3rd ed., Table T.4, the 1931 standard colorimetric observer; the same
# values as Wyszecki & Stiles, "Color Science", 2nd ed., Table I(3.3.1)), six decimals as
# published. Checked below: the maximum of y-bar is 1 at 555 nm, and the three sums are
# equal to 0.1 % (the functions are scaled to equal areas).
CIE_WAVELENGTHS_NM = np.arange(380.0, 781.0, 5.0)
CIE_1931_XBAR = np.array([
    0.001368, 0.002236, 0.004243, 0.007650, 0.014310, 0.023190, 0.043510, 0.077630,
    0.134380, 0.214770, 0.283900, 0.328500, 0.348280, 0.348060, 0.336200, 0.318700,
    0.290800, 0.251100, 0.195360, 0.142100, 0.095640, 0.057950, 0.032010, 0.014700,
    0.004900, 0.002400, 0.009300, 0.029100, 0.063270, 0.109600, 0.165500, 0.225750,
    0.290400, 0.359700, 0.433450, 0.512050, 0.594500, 0.678400, 0.762100, 0.842500,
    0.916300, 0.978600, 1.026300, 1.056700, 1.062200, 1.045600, 1.002600, 0.938400,
    0.854450, 0.751400, 0.642400, 0.541900, 0.447900, 0.360800, 0.283500, 0.218700,
    0.164900, 0.121200, 0.087400, 0.063600, 0.046770, 0.032900, 0.022700, 0.015840,
    0.011359, 0.008111, 0.005790, 0.004109, 0.002899, 0.002049, 0.001440, 0.001000,
    0.000690, 0.000476, 0.000332, 0.000235, 0.000166, 0.000117, 0.000083, 0.000059,
    0.000042,
])  # fmt: skip
CIE_1931_YBAR = np.array([
    0.000039, 0.000064, 0.000120, 0.000217, 0.000396, 0.000640, 0.001210, 0.002180,
    0.004000, 0.007300, 0.011600, 0.016840, 0.023000, 0.029800, 0.038000, 0.048000,
    0.060000, 0.073900, 0.090980, 0.112600, 0.139020, 0.169300, 0.208020, 0.258600,
    0.323000, 0.407300, 0.503000, 0.608200, 0.710000, 0.793200, 0.862000, 0.914850,
    0.954000, 0.980300, 0.994950, 1.000000, 0.995000, 0.978600, 0.952000, 0.915400,
    0.870000, 0.816300, 0.757000, 0.694900, 0.631000, 0.566800, 0.503000, 0.441200,
    0.381000, 0.321000, 0.265000, 0.217000, 0.175000, 0.138200, 0.107000, 0.081600,
    0.061000, 0.044580, 0.032000, 0.023200, 0.017000, 0.011920, 0.008210, 0.005723,
    0.004102, 0.002929, 0.002091, 0.001484, 0.001047, 0.000740, 0.000520, 0.000361,
    0.000249, 0.000172, 0.000120, 0.000085, 0.000060, 0.000042, 0.000030, 0.000021,
    0.000015,
])  # fmt: skip
CIE_1931_ZBAR = np.array([
    0.006450, 0.010550, 0.020050, 0.036210, 0.067850, 0.110200, 0.207400, 0.371300,
    0.645600, 1.039050, 1.385600, 1.622960, 1.747060, 1.782600, 1.772110, 1.744100,
    1.669200, 1.528100, 1.287640, 1.041900, 0.812950, 0.616200, 0.465180, 0.353300,
    0.272000, 0.212300, 0.158200, 0.111700, 0.078250, 0.057250, 0.042160, 0.029840,
    0.020300, 0.013400, 0.008750, 0.005750, 0.003900, 0.002750, 0.002100, 0.001800,
    0.001650, 0.001400, 0.001100, 0.001000, 0.000800, 0.000600, 0.000340, 0.000240,
    0.000190, 0.000100, 0.000050, 0.000030, 0.000020, 0.000010, 0.000000, 0.000000,
    0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
    0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
    0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000, 0.000000,
    0.000000,
])  # fmt: skip
CIE_1931_CMF = np.stack([CIE_1931_XBAR, CIE_1931_YBAR, CIE_1931_ZBAR], axis=-1)  # (81, 3)


def _xyz_to_srgb() -> np.ndarray:
    """XYZ -> linear sRGB, derived from the sRGB primaries' and the D65 white's xy
    chromaticities (IEC 61966-2-1: R 0.64 0.33, G 0.30 0.60, B 0.15 0.06, W 0.3127 0.3290)
    rather than copied as rounded numbers."""
    xy = np.array([[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]])
    primaries = np.stack([xy[:, 0] / xy[:, 1], np.ones(3), (1 - xy.sum(1)) / xy[:, 1]])  # columns
    w = np.array([0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290])
    rgb_to_xyz = primaries * np.linalg.solve(primaries, w)  # scale columns: white -> w
    return np.linalg.inv(rgb_to_xyz)


XYZ_TO_SRGB = _xyz_to_srgb()


# --- the spectral reference -------------------------------------------------------------------


def spectrum_to_rgb(reflectance: np.ndarray) -> np.ndarray:
    """Linear sRGB of reflectance spectra sampled at CIE_WAVELENGTHS_NM (last axis, 81):
    sum R(lambda) cmf(lambda) -> XYZ -> linear sRGB, each channel divided by a flat
    spectrum's (so a flat 1 is exactly (1, 1, 1)). Returns (..., 3)."""
    xyz = np.asarray(reflectance, np.float64) @ CIE_1931_CMF
    white = XYZ_TO_SRGB @ CIE_1931_CMF.sum(axis=0)
    return (xyz @ XYZ_TO_SRGB.T) / white


def airy_reflectance(
    eta_film: np.ndarray,
    film_ior: np.ndarray,
    thickness_nm: np.ndarray,
    eta_base: np.ndarray,
    k_base: np.ndarray,
    cos_theta: np.ndarray,
    wavelength_nm: np.ndarray,
) -> np.ndarray:
    """The exact unpolarised reflectance of the film at each wavelength (Airy's sum, in
    complex float64): indices relative to the medium of incidence (``eta_film`` = n2/n1,
    ``eta_base`` + i ``k_base`` = n3/n1), ``film_ior`` = n2 (absolute, for the optical path).
    Everything broadcasts. Past the film's critical angle the wave in the film is
    evanescent (cos(theta2) imaginary): the same formula then gives frustrated total
    internal reflection."""
    n2 = np.asarray(eta_film, np.float64).astype(complex)
    n3 = np.asarray(eta_base, np.float64) + 1j * np.asarray(k_base, np.float64)
    c1 = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    s1sq = 1.0 - c1 * c1
    c2 = np.sqrt(1.0 - s1sq / (n2 * n2))  # principal roots: Im >= 0, the decaying waves
    c3 = np.sqrt(1.0 - s1sq / (n3 * n3))
    delta = (
        4.0
        * np.pi
        * np.asarray(film_ior, np.float64)
        * np.asarray(thickness_nm)
        * (c2 / np.asarray(wavelength_nm, np.float64))
    )
    phase = np.exp(1j * delta)
    total = 0.0
    for r in (_r_s, _r_p):
        r12 = r(1.0, c1, n2, c2)
        r23 = r(n2, c2, n3, c3)
        total = total + np.abs((r12 + r23 * phase) / (1.0 + r12 * r23 * phase)) ** 2
    return 0.5 * total


def _r_s(na: complex, ca: complex, nb: complex, cb: complex) -> complex:
    """Fresnel's amplitude coefficient for s polarisation, from index na into nb."""
    return (na * ca - nb * cb) / (na * ca + nb * cb)


def _r_p(na: complex, ca: complex, nb: complex, cb: complex) -> complex:
    """For p polarisation (the sign convention in which r_p = -r_s at normal incidence;
    Airy's formula needs only the same convention at both interfaces)."""
    return (nb * ca - na * cb) / (nb * ca + na * cb)


def F_thin_film_spectral(
    eta_film: np.ndarray,
    film_ior: np.ndarray,
    thickness_nm: np.ndarray,
    eta_base: np.ndarray,
    k_base: np.ndarray,
    cos_theta: np.ndarray,
) -> np.ndarray:
    """The spectral reference: linear sRGB of Airy's reflectance summed over 380-780 nm in
    5 nm steps (``spectrum_to_rgb``). ``eta_base``, ``k_base`` (..., 3) are per RGB channel:
    channel c is the colour of a base whose index is channel c's at every wavelength (how an
    RGB renderer reads a per-channel index). Scalars ``eta_film``, ``film_ior``,
    ``thickness_nm``, ``cos_theta`` (...). Returns (..., 3)."""
    eta_base = np.asarray(eta_base, np.float64)[..., None]  # (..., 3, 1): channel, wavelength
    k_base = np.asarray(k_base, np.float64)[..., None]
    scalar = [
        np.asarray(x, np.float64)[..., None, None]
        for x in (eta_film, film_ior, thickness_nm, cos_theta)
    ]
    spectra = airy_reflectance(
        scalar[0], scalar[1], scalar[2], eta_base, k_base, scalar[3], CIE_WAVELENGTHS_NM
    )  # (..., 3 base channels, 81)
    rgb = spectrum_to_rgb(spectra)  # (..., 3 base channels, 3 rgb)
    return np.diagonal(rgb, axis1=-2, axis2=-1)


# --- Belcour and Barla 2017 -------------------------------------------------------------------

# Their Gaussian fits of the colour-matching functions in wavenumber (their supplemental
# code, evalSensitivity): value, position (1/m) and variance (1/m^2) of x (two lobes), y
# and z. S(OPD, shift) = val sqrt(2 pi var) cos(2 pi pos OPD + shift) exp(-4 pi^2 var OPD^2)
# is each lobe's integral against cos(2 pi OPD / lambda + shift), in closed form.
BB_VAL = np.array([5.4856e-13, 9.7470e-14, 4.4201e-13, 5.2481e-13])
BB_POS = np.array([1.6810e06, 2.2399e06, 1.7953e06, 2.2084e06])
BB_VAR = np.array([4.3278e09, 4.5282e09, 9.3046e09, 6.6121e09])
# Lobe -> XYZ: x = lobe 0 + lobe 1, y = lobe 2, z = lobe 3.
BB_LOBE_TO_XYZ = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

# Precision: the fits are in metres; scaled to nanometres (pos 1e-9, var 1e-18) so that the
# GLSL works with OPD in nm and no constant lies near float32's limits, and the amplitudes
# val sqrt(2 pi var) folded together with the lobe-to-RGB matrix, normalised so that
# OPD = 0 (a flat spectrum) gives exactly white: FILM_RGB[c, j] is lobe j's weight in
# channel c.
FILM_POS_NM = BB_POS * 1e-9
FILM_VAR_NM = BB_VAR * 1e-18
_lobe_rgb = XYZ_TO_SRGB @ BB_LOBE_TO_XYZ * (BB_VAL * np.sqrt(2.0 * np.pi * BB_VAR))  # (3, 4)
FILM_RGB = _lobe_rgb / _lobe_rgb.sum(axis=1, keepdims=True)

# Terms of the Fourier series kept (m = 1..FILM_TERMS; Belcour and Barla keep 3). Each term
# is r123^m smaller; docs/thin-film.md measures what the cut costs.
FILM_TERMS = 3

# Below this thickness (nm) the film fades in: F = mix(F_base, F_film, smoothstep(0,
# FILM_FADE_NM, d)), so that d = 0 gives the base's own Fresnel model exactly (Schlick
# included, which the film's exact interfaces are not). Belcour and Barla's code fades the
# film's index to the medium's for the same reason.
FILM_FADE_NM = 10.0


def film_sensitivity(opd_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, B), each (..., 3) in linear sRGB: the colour-matched integral of cos(2 pi OPD /
    lambda + shift) is A cos(shift) - B sin(shift) (the Gaussian fits' closed form, split
    by cos(a + b) = cos a cos b - sin a sin b so the shift can differ per channel and
    polarisation without evaluating the lobes again)."""
    x = np.asarray(opd_nm, np.float64)[..., None]
    damp = np.exp(-4.0 * np.pi * np.pi * FILM_VAR_NM * x * x)  # (..., 4)
    angle = 2.0 * np.pi * FILM_POS_NM * x
    return (damp * np.cos(angle)) @ FILM_RGB.T, (damp * np.sin(angle)) @ FILM_RGB.T


def film_top_interface(eta_film: np.ndarray, cos_theta: np.ndarray):
    """The medium -> film interface (real indices): (r_s, r_p, g, tir) with
    g = eta_film cos(theta2) and tir where no wave enters the film. Cancellation-free forms
    as in fresnel.F_dielectric (d = (eta - 1)(eta + 1), g = sqrt(d + c^2)):
    r_s = -d/(c + g)^2, r_p = d((eta^2 + 1) c^2 - 1)/(eta^2 c + g)^2."""
    eta = np.asarray(eta_film, np.float64)
    c = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    d = (eta - 1.0) * (eta + 1.0)
    g2 = d + c * c
    tir = g2 <= 0.0
    g = np.sqrt(np.maximum(g2, 0.0))
    e2 = eta * eta
    gc = g + c
    q = e2 * c + g
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = -d / np.maximum(gc * gc, 1e-30)
        rp = d * ((e2 + 1.0) * c * c - 1.0) / np.maximum(q * q, 1e-30)
    return rs, rp, g, tir


def film_base_interface(
    eta: np.ndarray, k: np.ndarray, cos_theta: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The film -> base interface for the complex relative index eta + i k (..., 3) at the
    real angle cos_theta (...) in the film: (R_s, phi_s, R_p, phi_p), each (..., 3):
    r_s = (c - w)/(c + w), r_p = (eta_c^2 c - w)/(eta_c^2 c + w), w = sqrt(eta_c^2 - s^2)
    with Im w >= 0 (the wave decaying into the base), taken from the larger of
    (|w^2| +- Re w^2)/2 as in fresnel.F_conductor. A phase is 0 where R is 0."""
    eta = np.asarray(eta, np.float64)
    k = np.asarray(k, np.float64)
    c = np.asarray(cos_theta, np.float64)[..., None]
    c2 = c * c
    e2_re = (eta - k) * (eta + k)  # Re(eta_c^2)
    e2_im = 2.0 * eta * k  # Im(eta_c^2) >= 0
    t = e2_re - (1.0 - c2)  # Re(w^2)
    m = np.sqrt(t * t + e2_im * e2_im)
    big = np.sqrt(0.5 * (m + np.abs(t)))
    small = 0.5 * e2_im / np.maximum(big, 1e-30)
    w_re = np.where(t < 0.0, small, big)
    w_im = np.where(t < 0.0, big, small)

    def ratio(a_re, a_im):  # (a - w)/(a + w) for a complex a
        n_re, n_im = a_re - w_re, a_im - w_im
        d_re, d_im = a_re + w_re, a_im + w_im
        den = np.maximum(d_re * d_re + d_im * d_im, 1e-30)
        return (n_re * d_re + n_im * d_im) / den, (n_im * d_re - n_re * d_im) / den

    out = []
    for a_re, a_im in ((c + 0.0 * eta, 0.0 * eta), (e2_re * c, e2_im * c)):
        r_re, r_im = ratio(a_re, a_im)
        R = r_re * r_re + r_im * r_im
        out += [R, np.where(R > 0.0, np.arctan2(r_im, r_re), 0.0)]
    return out[0], out[1], out[2], out[3]


def F_thin_film(
    eta_film: np.ndarray,
    film_ior: np.ndarray,
    thickness_nm: np.ndarray,
    eta_base: np.ndarray,
    k_base: np.ndarray,
    cos_theta: np.ndarray,
) -> np.ndarray:
    """Belcour and Barla 2017: the film's reflectance in linear sRGB, (..., 3), clamped to
    [0, 1]. Arguments as ``F_thin_film_spectral``. Per polarisation, with R12 and R23 the
    interfaces' reflectances, T121 = 1 - R12, phi = arg(r21) + arg(r23) and
    Rs = T121^2 R23 / (1 - R12 R23), Airy's R(delta) is exactly
        C0 + 2 sum_{m >= 1} C_m cos(m (delta + phi)),  C0 = R12 + Rs,
        C_m = (Rs - T121) sqrt(R12 R23)^m,
    and each cos integrates against the colour-matching functions through
    ``film_sensitivity`` at m OPD. Total reflection at the top (a film of lower index past
    its critical angle) gives 1: the frustrated total reflection of a very thin such film
    is left out (the spectral reference has it)."""
    eta_film = np.asarray(eta_film, np.float64)
    c1 = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    rs12, rp12, g, tir = film_top_interface(eta_film, c1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos2 = np.where(tir, 1.0, g / eta_film)
    opd = 2.0 * np.asarray(film_ior, np.float64) * np.asarray(thickness_nm, np.float64) * cos2
    # The base's index relative to the film's.
    inv = (1.0 / eta_film)[..., None]
    Rs23, phs23, Rp23, php23 = film_base_interface(
        np.asarray(eta_base, np.float64) * inv, np.asarray(k_base, np.float64) * inv, cos2
    )
    total = 0.0
    for r12, R23, phi23 in ((rs12, Rs23, phs23), (rp12, Rp23, php23)):
        R12 = (r12 * r12)[..., None]
        phi21 = np.where(r12 > 0.0, np.pi, 0.0)[..., None]  # arg(r21) = arg(-r12)
        T121 = 1.0 - R12
        R123 = R12 * R23
        r123 = np.sqrt(R123)
        Rs = T121 * T121 * R23 / np.maximum(1.0 - R123, 1e-30)
        I = R12 + Rs
        Cm = Rs - T121
        phi = phi21 + phi23
        for m in range(1, FILM_TERMS + 1):
            Cm = Cm * r123
            A, B = film_sensitivity(m * opd)
            I = I + 2.0 * Cm * (A * np.cos(m * phi) - B * np.sin(m * phi))
        total = total + I
    F = np.clip(0.5 * total, 0.0, 1.0)
    return np.where(tir[..., None], 1.0, F)


def ior_from_f0_rgb(F0: np.ndarray) -> np.ndarray:
    """The real index whose normal-incidence reflectance is F0 (F0 clamped to 0.99, so a
    white metal gets 399, not infinity): n = (1 + sqrt F0)/(1 - sqrt F0). How the metalness
    workflow's base colour becomes an index under the film (glTF KHR_materials_iridescence
    does the same; the metal's k is unknown there and taken as 0)."""
    s = np.sqrt(np.clip(np.asarray(F0, np.float64), 0.0, 0.99))
    return (1.0 + s) / (1.0 - s)
