"""Twin of glsl/material/filtering.glsl: roughness that absorbs the normals a pixel or a texel
averages (RTR4 §9.13, "Blending and Filtering Materials").

Two kinds of filtering meet here, both as changes of alpha^2 (alpha = r^2, r the perceptual
roughness), because the variance of a distribution of slopes adds to the NDF's alpha^2:

* screen space, per pixel, in the G-buffer shader: ``alpha2_specular_aa`` and
  ``perceptual_roughness_specular_aa`` (the GLSL functions of the same names);
* texture space, per mip texel, on the CPU: ``alpha2_toksvig`` and
  ``alpha2_from_slope_variance``, which app/textures/mips.py applies to the moments of each
  texel's footprint, and ``slope_covariance`` (app/textures/lean.py). They have no GLSL
  counterpart: the renderer samples their result;
* both: LEAN's covariance, sampled per pixel and added to the material's lobe as
  anisotropic roughness, ``lean_anisotropic_roughness`` (the GLSL function of that name),
  with the spread factor ``GGX_LEAN_SPREAD`` for GGX lobes (derived below from
  ``ggx_slope_marginal`` and measured by ``ggx_lean_lobe_errors``).

Every function is float64 and broadcasts over leading axes (vectors on the last axis).
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from app.reference._vec import dot
from app.reference.chain import chain_slope

# Tokuyoshi & Kaplanyan 2019, their deferred-shading listing: the variance of the pixel filter
# in pixels^2 (a Gaussian of standard deviation 1/2 pixel, so that +-2 sigma spans one pixel)
# and the most the filter may add to alpha^2. Their 2021 JCGT sequel uses 1/(2 pi) = 0.159
# for SIGMA2; the scene format exposes both values (render.specular_aa_variance/_threshold).
SPECULAR_AA_SIGMA2 = 0.25
SPECULAR_AA_KAPPA = 0.18


# The fraction of a Gaussian's mass within one standard deviation of its mean, erf(1/sqrt 2).
ONE_SIGMA_MASS = math.erf(1.0 / math.sqrt(2.0))


def ggx_lean_spread(fraction: float = ONE_SIGMA_MASS) -> float:
    """The factor k of GGX's LEAN mapping alpha'^2 = alpha^2 + 2 k sigma^2: the GGX
    lobe whose central interval holding ``fraction`` of its slopes (along an axis) is the
    one that holds it for a Gaussian of variance sigma^2, where the spread dominates the
    material's roughness (sigma >> alpha).

    GGX's slope distribution is a bivariate Student t with 2 degrees of freedom: its
    variance is infinite, so Beckmann's variance matching (k = 1) has no GGX counterpart.
    Its marginal along an axis (``ggx_slope_marginal``) has the CDF
    1/2 + x / (2 sqrt(alpha^2 + x^2)), so +-w holds f of it where w = alpha f / sqrt(1 - f^2);
    a Gaussian's +-z sigma holds f where z = Phi^-1((1 + f)/2). Equal intervals give
    alpha'^2 = 2 k sigma^2 with k = z^2 (1 - f^2) / (2 f^2): 0.573 for the one-sigma
    interval (z = 1, the default), 0.682 for the quartiles (f = 1/2; the 2-D median
    radius gives ln 2 = 0.693), falling to 0 as f -> 1 (GGX's tails hold ever more of
    its mass). docs/filtering.md measures the choice."""
    f = float(fraction)
    z = NormalDist().inv_cdf(0.5 + 0.5 * f)
    return z * z * (1.0 - f * f) / (2.0 * f * f)


# LEAN's spread factor for GGX lobes (glsl/material/filtering.glsl GGX_LEAN_SPREAD; Beckmann's
# Gaussian slopes keep 1, the variance matching): 0.5728.
GGX_LEAN_SPREAD = ggx_lean_spread()


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def alpha2_specular_aa(
    alpha2: np.ndarray | float,
    dndx: np.ndarray,
    dndy: np.ndarray,
    sigma2: np.ndarray | float = SPECULAR_AA_SIGMA2,
    kappa: np.ndarray | float = SPECULAR_AA_KAPPA,
) -> np.ndarray:
    """Tokuyoshi & Kaplanyan 2019, "Improved Geometric Specular Antialiasing", the isotropic
    kernel for deferred shading (after Kaplanyan et al. 2016): the pixel footprint's normal
    variance added to alpha^2.

    variance = sigma2 (|dn/dx|^2 + |dn/dy|^2); kernel = min(2 variance, kappa);
    alpha2' = clamp(alpha2 + kernel, 0, 1). ``dndx``, ``dndy`` (..., 3): screen-space
    derivatives of the shading normal; ``alpha2``, ``sigma2``, ``kappa`` (...) or scalars.
    """
    with np.errstate(over="ignore"):  # huge derivatives: the kernel is clamped to kappa
        variance = _f64(sigma2) * (dot(dndx, dndx) + dot(dndy, dndy))
    kernel = np.minimum(2.0 * variance, _f64(kappa))
    return np.clip(_f64(alpha2) + kernel, 0.0, 1.0)


def perceptual_roughness_specular_aa(
    r: np.ndarray | float,
    dndx: np.ndarray,
    dndy: np.ndarray,
    sigma2: np.ndarray | float = SPECULAR_AA_SIGMA2,
    kappa: np.ndarray | float = SPECULAR_AA_KAPPA,
) -> np.ndarray:
    """Tokuyoshi & Kaplanyan 2019 on perceptual roughness: r -> alpha^2 = r^4 ->
    ``alpha2_specular_aa`` -> r' = (alpha2')^(1/4)."""
    a = _f64(r) * _f64(r)
    return np.sqrt(np.sqrt(alpha2_specular_aa(a * a, dndx, dndy, sigma2, kappa)))


def alpha2_toksvig(
    alpha2: np.ndarray | float, mean_normal_length: np.ndarray | float
) -> np.ndarray:
    """Toksvig 2005, "Mipmapping Normal Maps", with Walter et al. 2007's Blinn-Phong <->
    Beckmann mapping s = 2/alpha^2 - 2: alpha^2 widened by the shortening |Na| of the mean
    of the unit normals a texel averages.

    ft = |Na| / (|Na| + s (1 - |Na|)), s' = ft s, alpha'^2 = 2 / (s' + 2). Multiplying
    through by alpha^2 gives the same value without s (infinite at alpha = 0):
    alpha'^2 = D / (|Na| (1 - alpha^2) + D), D = |Na| alpha^2 + 2 (1 - alpha^2)(1 - |Na|).
    |Na| = 1 returns alpha^2; alpha^2 = 1 returns 1; alpha^2 = 0 returns
    2 (1 - |Na|) / (2 - |Na|). The one 0/0 (|Na| = 0 with alpha^2 = 1: normals that cancel
    out, impossible for tangent-space normals with z > 0) returns 1.
    """
    a2 = np.clip(_f64(alpha2), 0.0, 1.0)
    na = np.clip(_f64(mean_normal_length), 0.0, 1.0)
    d = na * a2 + 2.0 * (1.0 - a2) * (1.0 - na)
    den = na * (1.0 - a2) + d
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0.0, d / np.where(den > 0.0, den, 1.0), 1.0)


def alpha2_from_slope_variance(
    alpha2: np.ndarray | float, sigma2: np.ndarray | float
) -> np.ndarray:
    """Olano & Baker 2010, "LEAN Mapping" (slope moments), with the Beckmann mapping: a
    Beckmann lobe of roughness alpha has slope variance alpha^2/2 per axis, and variances of
    independent slopes add, so alpha'^2 = min(1, alpha^2 + 2 sigma^2) with sigma^2 the
    per-axis variance of the slopes of the normals a texel averages."""
    return np.minimum(1.0, _f64(alpha2) + 2.0 * np.maximum(_f64(sigma2), 0.0))


def slope_covariance(moments: np.ndarray) -> np.ndarray:
    """Olano & Baker 2010, "LEAN Mapping": the covariance of a footprint's tangent-space
    slopes from its mean moments, Sigma = M - B B^T with B = E[s] and M = E[s s^T].

    ``moments`` (..., 5): E[s.x], E[s.y], E[s.x^2], E[s.y^2], E[s.x s.y]; returns (..., 3):
    Sigma_xx, Sigma_yy, Sigma_xy, the variances clamped at 0 against the rounding of
    E[s^2] - E[s]^2."""
    m = _f64(moments)
    bx, by = m[..., 0], m[..., 1]
    var_x = np.maximum(m[..., 2] - bx * bx, 0.0)
    var_y = np.maximum(m[..., 3] - by * by, 0.0)
    return np.stack([var_x, var_y, m[..., 4] - bx * by], axis=-1)


# ``render.normal_filter = "auto"``: a normal map whose spread of slopes under a texel keeps
# one direction gets LEAN's covariance, any other the isotropic variance chain. The spread
# is measured over footprints of each of SPREAD_FOOTPRINTS^2 texels (mip levels 3 and 4, in
# turn: the second only where the first is directional), SPREAD_SAMPLE / footprint a side
# sampled evenly over the map (at most 512^2 texels a level: 64^2 footprints at level 3,
# 32^2 at level 4; a 2048^2 map's 6%); the map is directional where, at both, the mean
# footprint covariance's eigenvalues differ by DIRECTIONAL_ANISOTROPY of their sum
# ((l1 - l2)/(l1 + l2) = 0.6: l1 = 4 l2) and its trace reaches DIRECTIONAL_MIN_SPREAD (a
# slope spread of some 2.5 degrees, a GGX lobe's alpha^2 at perceptual roughness 0.2; a
# smaller spread changes the lobe too little to pay for LEAN). Two levels, because a bump
# pattern whose period is twice a footprint can look one-way in footprints locked to its
# phase and round in the next level's. docs/filtering.md measures the choice on groove
# maps and Khronos' normal maps.
SPREAD_FOOTPRINTS = (8, 16)
SPREAD_FOOTPRINT = SPREAD_FOOTPRINTS[0]
SPREAD_SAMPLE = 512
DIRECTIONAL_ANISOTROPY = 0.6
DIRECTIONAL_MIN_SPREAD = 0.002


def spread_sample_origins(size: int, footprint: int = SPREAD_FOOTPRINT) -> tuple[np.ndarray, int]:
    """The first texel of each sampled footprint along an axis of ``size`` texels: at most
    SPREAD_SAMPLE / ``footprint`` footprints of ``footprint`` texels, on the footprint grid
    (as a mip level's texels lie), spread evenly from the start. An axis shorter than one
    footprint is one footprint of all its texels (returned as [0] with the axis' size)."""
    whole = size // footprint
    if whole == 0:
        return np.zeros(1, np.int64), size
    count = min(whole, SPREAD_SAMPLE // footprint)
    return (np.arange(count, dtype=np.int64) * whole // count) * footprint, footprint


def mean_footprint_covariance(normals: np.ndarray, footprint: int = SPREAD_FOOTPRINT) -> np.ndarray:
    """The mean over sampled footprints (``spread_sample_origins`` on both axes) of the
    covariance of the tangent-space slopes s = -n.xy / n.z under each (``slope_covariance``
    of its moments), from (H, W, 3) unit normals: (3,) Sigma_xx, Sigma_yy, Sigma_xy. n.z is
    floored as the chains floor it (``chain_slope``, app/reference/chain.py)."""
    n = _f64(normals)
    xs, fx = spread_sample_origins(n.shape[1], footprint)
    ys, fy = spread_sample_origins(n.shape[0], footprint)
    covariances = []
    for y in ys:
        for x in xs:
            block = n[y : y + fy, x : x + fx].reshape(-1, 3)
            sx, sy = np.moveaxis(chain_slope(block), -1, 0)
            moments = np.array([sx.mean(), sy.mean(), (sx * sx).mean(), (sy * sy).mean(),
                                (sx * sy).mean()])  # fmt: skip
            covariances.append(slope_covariance(moments))
    return np.mean(covariances, axis=0)


def spread_anisotropy(covariance: np.ndarray) -> tuple[float, float]:
    """(anisotropy, trace) of a 2x2 slope covariance (Sigma_xx, Sigma_yy, Sigma_xy): its
    eigenvalues l1 >= l2 give (l1 - l2)/(l1 + l2) (0 isotropic, 1 a spread along one
    direction alone) and l1 + l2, the total slope variance."""
    xx, yy, xy = (float(c) for c in covariance)
    trace = xx + yy
    difference = math.sqrt((xx - yy) ** 2 + 4.0 * xy * xy)
    return (difference / trace if trace > 0.0 else 0.0), trace


def directional_spread(covariances: np.ndarray) -> bool:
    """Whether ``render.normal_filter = "auto"`` picks ``lean`` for a normal map whose mean
    footprint covariances are ``covariances`` ((k, 3) or (3,): one per footprint size of
    SPREAD_FOOTPRINTS measured, constants above): every one directional."""
    for covariance in np.reshape(covariances, (-1, 3)):
        anisotropy, trace = spread_anisotropy(covariance)
        if anisotropy < DIRECTIONAL_ANISOTROPY or trace < DIRECTIONAL_MIN_SPREAD:
            return False
    return True


def lean_anisotropic_roughness(
    r: np.ndarray | float,
    anisotropy: np.ndarray | float,
    direction: np.ndarray,
    sigma: np.ndarray,
    spread: np.ndarray | float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Olano & Baker 2010, "LEAN Mapping": a filtered normal map's slope covariance
    ``sigma`` (..., 3: Sigma_xx, Sigma_yy, Sigma_xy in the tangent frame (t, b)) added to the
    material's own lobe, and the sum turned back into the anisotropic GGX/Beckmann
    parameters the G-buffer stores (RTR4 §9.8: alpha_x = alpha (1 + a) along the tangent,
    alpha_y = alpha (1 - a) across it, alpha = r^2).

    The material's lobe (perceptual roughness ``r``, ``anisotropy`` a, unit ``direction``
    (..., 2) of its tangent in (t, b)) is the alpha^2 tensor
    A = alpha_x^2 d d^T + alpha_y^2 d_perp d_perp^T; a lobe of roughness alpha has slope
    variance alpha^2/2 per axis (Beckmann), so the normal map's spread adds 2 Sigma:
    A' = A + 2 k Sigma with ``spread`` k = 1 for Beckmann lobes and ``GGX_LEAN_SPREAD``
    for GGX lobes, whose slopes have no variance to match (``ggx_lean_spread``). Its
    eigenvalues lambda_1 >= lambda_2 (clamped to [0, 1]) are
    alpha_x'^2 and alpha_y'^2, its major eigenvector the new tangent direction:
    lambda = m +- q, m = (A'_xx + A'_yy)/2, q = sqrt(((A'_xx - A'_yy)/2)^2 + A'_xy^2); the
    eigenvector of lambda_1 is ((A'_xx - A'_yy)/2 + q, A'_xy) where A'_xx >= A'_yy, else
    (A'_xy, (A'_yy - A'_xx)/2 + q) (each the longer of the two forms, never a cancellation),
    ``direction`` itself where q = 0 (an isotropic sum: every axis is one).
    Returns (r', a', direction'): r' = sqrt((alpha_x' + alpha_y')/2),
    a' = (alpha_x' - alpha_y')/(alpha_x' + alpha_y') (0 where both are 0), direction' unit.
    With sigma = 0 this gives back the material (up to the sign of d and a, one axis).
    Every argument broadcasts over leading axes."""
    alpha = _f64(r) * _f64(r)
    a = _f64(anisotropy)
    d = _f64(direction)
    s = _f64(sigma) * (2.0 * _f64(spread))[..., None]
    ax2 = (alpha * (1.0 + a)) ** 2
    ay2 = (alpha * (1.0 - a)) ** 2
    dx, dy = d[..., 0], d[..., 1]
    axx = ax2 * dx * dx + ay2 * dy * dy + s[..., 0]
    ayy = ax2 * dy * dy + ay2 * dx * dx + s[..., 1]
    axy = (ax2 - ay2) * dx * dy + s[..., 2]
    half = 0.5 * (axx - ayy)
    mean = 0.5 * (axx + ayy)
    q = np.sqrt(half * half + axy * axy)
    l1 = np.clip(mean + q, 0.0, 1.0)
    l2 = np.clip(mean - q, 0.0, 1.0)
    ex = np.where(half >= 0.0, half + q, axy)
    ey = np.where(half >= 0.0, axy, -half + q)
    length = np.sqrt(ex * ex + ey * ey)
    ok = length > 0.0
    safe = np.where(ok, length, 1.0)
    e = np.stack([np.where(ok, ex / safe, dx), np.where(ok, ey / safe, dy)], axis=-1)
    alpha_x, alpha_y = np.sqrt(l1), np.sqrt(l2)
    total = alpha_x + alpha_y
    a_new = np.where(total > 0.0, (alpha_x - alpha_y) / np.where(total > 0.0, total, 1.0), 0.0)
    return np.sqrt(0.5 * total), a_new, e


def ggx_slope_pdf(sx: np.ndarray, sy: np.ndarray, ax: float, ay: float) -> np.ndarray:
    """GGX's distribution of slopes (Walter et al. 2007; Heitz 2014, P22), anisotropic
    along the axes: 1 / (pi ax ay (1 + (sx/ax)^2 + (sy/ay)^2)^2), unit mass over the plane
    (the NDF is this over cos^4 theta)."""
    t = 1.0 + (_f64(sx) / ax) ** 2 + (_f64(sy) / ay) ** 2
    return 1.0 / (math.pi * ax * ay * t * t)


def ggx_slope_marginal(x: np.ndarray, alpha: float) -> np.ndarray:
    """The isotropic GGX slope distribution's marginal along one axis (a Student t with 2
    degrees of freedom, scale alpha/sqrt 2): alpha^2 / (2 (alpha^2 + x^2)^(3/2))."""
    x = _f64(x)
    return alpha * alpha / (2.0 * (alpha * alpha + x * x) ** 1.5)


def _gaussian_kernel(sigma: float, step: float) -> np.ndarray:
    """A normalised Gaussian of standard deviation ``sigma`` sampled every ``step`` out to
    8 sigma (a single 1 where it is narrower than a sample)."""
    half = math.ceil(8.0 * sigma / step)
    if half == 0:
        return np.ones(1)
    t = np.arange(-half, half + 1) * step
    g = np.exp(-0.5 * (t / sigma) ** 2)
    return g / g.sum()


def _convolve_same(signal: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """np.convolve(signal, kernel, "same") for an odd kernel, through the FFT."""
    n = len(signal) + len(kernel) - 1
    full = np.fft.irfft(np.fft.rfft(signal, n) * np.fft.rfft(kernel, n), n)
    half = len(kernel) // 2
    return full[half : half + len(signal)]


def convolved_interval_alpha(
    alpha: float, sigma: float, fraction: float = ONE_SIGMA_MASS, samples: int = 200001
) -> float:
    """The GGX alpha' whose slope marginal holds ``fraction`` within the same central
    interval as GGX(alpha) convolved with a Gaussian of standard deviation ``sigma`` (the
    material's lobe filtered by a footprint of slope variance sigma^2, LEAN's model):
    float64, the convolution on a grid of ``samples`` slopes over +-(2000 alpha + 10 sigma),
    the interval from its CDF; the GGX marginal's mass beyond the grid (alpha/2000 of it)
    added back to the ends. ``ggx_lean_spread`` is its limit: (alpha'^2 - alpha^2) / (2
    sigma^2) -> k as sigma/alpha grows."""
    reach = 2000.0 * alpha + 10.0 * sigma
    x = np.linspace(-reach, reach, samples)
    step = x[1] - x[0]
    pdf = ggx_slope_marginal(x, alpha) * step
    lost = 0.5 - 0.5 * reach / math.sqrt(alpha * alpha + reach * reach)  # each side
    conv = _convolve_same(pdf, _gaussian_kernel(sigma, step))
    cdf = lost + np.cumsum(conv) - 0.5 * conv  # each sample's mass centred on it
    w = float(np.interp(0.5 + 0.5 * fraction, cdf, x))
    return w * math.sqrt(1.0 - fraction * fraction) / fraction


def ggx_lean_lobe_errors(
    alpha: float, sigma: float, spread: float, reach: float = 1.0, samples: int = 801
) -> tuple[float, float]:
    """How well LEAN's GGX lobe (alpha_x'^2 = alpha^2 + 2 ``spread`` sigma^2 across, alpha
    along) stands for the filtered lobe it replaces, GGX(alpha) convolved with slopes of
    variance sigma^2 across (a groove map's footprint): (L1, tail). L1: the integral of
    |fit - filtered| over the slopes within +-``reach`` (the mass of reflected light sent in
    the wrong directions, of 1). tail: the fit's mass beyond slope ``reach`` (45 degrees by
    default) over the filtered lobe's, the light a GGX lobe's tails reflect where the
    footprint reflects almost none. Float64 on a ``samples``^2 grid."""
    x = np.linspace(-reach, reach, samples)
    step = x[1] - x[0]
    kernel = _gaussian_kernel(sigma, step)
    pad = len(kernel) // 2
    xs = x[0] + step * np.arange(-pad, samples + pad)
    sx, sy = np.meshgrid(xs, x, indexing="xy")
    own = ggx_slope_pdf(sx, sy, alpha, alpha)
    filtered = np.apply_along_axis(np.convolve, 1, own, kernel, mode="valid")
    fx, fy = np.meshgrid(x, x, indexing="xy")
    fit = ggx_slope_pdf(fx, fy, math.sqrt(alpha * alpha + 2.0 * spread * sigma * sigma), alpha)
    area = step * step
    l1 = float(np.abs(fit - filtered).sum() * area)
    tail_fit = 1.0 - float(fit.sum() * area)
    tail_filtered = 1.0 - float(filtered.sum() * area)
    return l1, tail_fit / tail_filtered
