"""Twin of glsl/brdf/sheen.glsl: a cloth sheen layer over any base BRDF (RTR4 §9.10).

Cloth seen at grazing angles glows with light scattered forward by fibres that stand up from
the surface. The microfacet way to draw it (RTR4 §9.10) is an NDF that puts its microfacets
near the horizon, not near n, with a softer visibility term than Smith's:

* "Charlie" (Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF"):
  D(m) = chi+(n.m) (2 + 1/alpha) sin(theta_m)^(1/alpha) / (2 pi);
* Ashikhmin's inverted Gaussian (Ashikhmin, Premoze & Shirley 2000; Ashikhmin & Premoze
  2007, "Distribution-based BRDFs"):
  D(m) = chi+(n.m) (1 + k_amp exp(-cot^2(theta_m)/alpha^2) / sin^4(theta_m))
         / (pi (1 + k_amp alpha^2)),
  k_amp = 4 as published;
* both with the "distribution-based" visibility of Ashikhmin & Premoze 2007, which Neubelt &
  Pettineo 2013 ("Crafting a Next-Gen Material Pipeline for The Order: 1886") adopted:
  V = 1/(4 (n.l + n.v - (n.l)(n.v))), so f_sheen = sheen_color D(h) V, with no Fresnel;
* "charlie_smith": Charlie's D with Estevez & Kulla 2017's own fit of its Smith Lambda in the
  height-correlated G2 = 1/(1 + Lambda(n.l) + Lambda(n.v)) (RTR4 §9.7), V = G2/(4 n.l n.v):
  the accurate visibility, whose lobe no longer reflects more than arrives at grazing
  angles (docs/cloth.md measures what the fit gets wrong).

The layer goes over the base as glTF's KHR_materials_sheen arranges it (its "albedo
scaling"): f = f_sheen + f_base (1 - max(sheen_color) max(E(n.l), E(n.v))), where E(mu) is
the sheen lobe's directional albedo with sheen_color = 1. The max over both directions (glTF:
min of the two scalings) keeps f reciprocal; the view-only variant would not be.

E is a table (``compute_table``, shipped as app/common/data/sheen_table_64.npy and bound as
the texture u_sheen_table), computed here by deterministic quadrature of the exact lobe
(``sheen_albedo``), not an analytic fit: Charlie's E with Neubelt's V falls from 8.8 to
1e-4 between n.v = 0 and 0.3 at the roughness floor, and a polynomial in (sqrt(mu), r) of
degree 5 x 5 fitted to ln E still misses E by 0.17 (measured while choosing; Ashikhmin's
smoother E fits to 8e-3). The table is read like the multiple-scattering table: bilinear in
(sqrt(sqrt(mu)), sqrt((r - 0.045)/0.955)) by hand, the same sums in GLSL and here.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from app.common.tables import SHEEN_TABLE_SIZE, read_sheen_table, sheen_table_path
from app.reference._vec import dot
from app.reference.constants import MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS, PI
from app.reference.multiscatter import _save, mu_coord, mu_grid, r_coord, roughness_grid
from app.reference.quadrature import N, cosine_rule, gauss_legendre

# Ashikhmin & Premoze 2007's amplitude of the inverted Gaussian ("A = 4" in their velvet).
ASHIKHMIN_AMPLITUDE = 4.0
# The inverted Gaussian's exponent beyond which the GLSL drops it: exp(-87) is float32's
# normal floor (as Beckmann's cut-off in app/reference/ndf.py).
ASHIKHMIN_EXPONENT_CUTOFF = 87.0
# Charlie's ln(sin^2) below which the GLSL returns 0 for D (sin^2 <= 1e-30 is the same
# guard against ln(0) as Blinn-Phong's).
SIN2_FLOOR = 1e-30


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def sheen_alpha(sheen_roughness: np.ndarray | float) -> np.ndarray:
    """alpha = r^2 with r floored at MIN_PERCEPTUAL_ROUGHNESS, as the base's alpha."""
    r = np.maximum(_f64(sheen_roughness), MIN_PERCEPTUAL_ROUGHNESS)
    return r * r


def D_charlie(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Estevez & Kulla 2017: D = chi+(n.m) (2 + 1/alpha) sin(theta_m)^(1/alpha) / (2 pi).

    sin^(1/alpha) = exp(ln(sin^2)/(2 alpha)) with sin^2 = |n x m|^2, and ln(sin^2) =
    ln(1 - (n.m)^2) (log1p) where (n.m)^2 < 1/4, i.e. at the lobe's peak near the horizon.
    """
    NoM = dot(n, m)
    nxm = np.cross(_f64(n), _f64(m))
    s2 = np.maximum(dot(nxm, nxm), SIN2_FLOOR)
    c2 = NoM * NoM
    inv_a = 1.0 / _f64(alpha)
    ln_s2 = np.where(c2 < 0.25, np.log1p(-np.minimum(c2, 0.25)), np.log(s2))
    D = (2.0 + inv_a) * (0.5 / PI) * np.exp(0.5 * inv_a * ln_s2)
    return np.where(NoM > 0.0, D, 0.0)


def D_ashikhmin(n: np.ndarray, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Ashikhmin & Premoze 2007 inverted Gaussian, amplitude k_amp = 4:
    D = chi+(n.m) (1 + k_amp exp(-cot^2/alpha^2) / sin^4) / (pi (1 + k_amp alpha^2)).

    cot^2/alpha^2 = (n.m)^2 / (alpha^2 |n x m|^2); the Gaussian is dropped where that
    exponent exceeds the cut-off, tested as a product as in the GLSL (so sin = 0 drops it)."""
    NoM = dot(n, m)
    nxm = np.cross(_f64(n), _f64(m))
    s2 = dot(nxm, nxm)
    a2 = _f64(alpha) ** 2
    c2 = NoM * NoM
    keep = c2 <= ASHIKHMIN_EXPONENT_CUTOFF * a2 * s2
    s2_safe = np.where(keep, s2, 1.0)
    bump = np.where(
        keep, ASHIKHMIN_AMPLITUDE * np.exp(-c2 / (a2 * s2_safe)) / (s2_safe * s2_safe), 0.0
    )
    D = (1.0 + bump) / (PI * (1.0 + ASHIKHMIN_AMPLITUDE * a2))
    return np.where(NoM > 0.0, D, 0.0)


def V_neubelt(NoL: np.ndarray, NoV: np.ndarray) -> np.ndarray:
    """Ashikhmin & Premoze 2007; Neubelt & Pettineo 2013: V = 1/(4 (n.l + n.v - n.l n.v)),
    the sum taken as n.l + n.v (1 - n.l): every term >= 0, no cancellation."""
    NoL, NoV = _f64(NoL), _f64(NoV)
    return 1.0 / (4.0 * (NoL + NoV * (1.0 - NoL)))


# Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF", their table of the fit
# L(x) = a/(1 + b x^c) + d x + e to ln Lambda of the Charlie NDF: (a, b, c, d, e) at their r = 0
# and r = 1. Their r is the exponent parameter of D (sin^(1/r)), i.e. this project's
# alpha = sheen_roughness^2 (glTF KHR_materials_sheen reads it the same way); measured
# against the Lambda by quadrature, reading r as the perceptual roughness fits worse
# (docs/cloth.md).
CHARLIE_LAMBDA_FIT_R0 = (25.3245, 3.32435, 0.16801, -1.27393, -4.85967)
CHARLIE_LAMBDA_FIT_R1 = (21.5473, 3.82987, 0.19823, -1.97760, -4.32054)


def charlie_L(x: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Estevez & Kulla 2017: L(x) = a/(1 + b x^c) + d x + e, each coefficient
    p = p1 + t (p0 - p1) with t = (1 - alpha)^2 between their fits at r = 0 (p0) and 1 (p1).

    x^c for x = 0 is written as 0 (GLSL's pow(0, c) is defined for c > 0, but the GLSL
    writes the branch out so no driver's exp2(c log2(0)) is relied on)."""
    x = _f64(x)
    t = (1.0 - _f64(alpha)) ** 2
    a, b, c, d, e = (
        p1 + t * (p0 - p1)
        for p0, p1 in zip(CHARLIE_LAMBDA_FIT_R0, CHARLIE_LAMBDA_FIT_R1, strict=True)
    )
    xc = np.where(x > 0.0, np.power(np.maximum(x, 1e-300), c), 0.0)
    return a / (1.0 + b * xc) + d * x + e


def Lambda_charlie(mu: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Estevez & Kulla 2017's Smith Lambda of the Charlie NDF (RTR4 §9.7):
    exp(L(mu)) for mu < 0.5, exp(2 L(0.5) - L(1 - mu)) otherwise.

    Precision: L is at most a + e (20.47 at alpha = 0, where mu = 0), so Lambda stays below
    7.7e8, far inside float32; at mu = 1 it is ~1e-8 (exp(-18.7) at alpha = 0). Neither end
    needs a guard; the fit does not grow without bound as mu -> 0, as the true Lambda (~ 1/mu)
    does."""
    mu = _f64(mu)
    low = np.exp(charlie_L(np.minimum(mu, 0.5), alpha))
    high = np.exp(2.0 * charlie_L(0.5, alpha) - charlie_L(1.0 - np.maximum(mu, 0.5), alpha))
    return np.where(mu < 0.5, low, high)


def V_charlie_smith(NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The height-correlated Smith visibility G2/(4 n.l n.v) with Charlie's Lambda (RTR4
    §9.7): 1/(4 n.l n.v (1 + Lambda(n.l) + Lambda(n.v))). Symmetric in (n.l, n.v).

    n.l enters at the floor n.v already has, MIN_N_DOT_V = 1e-4. Below it the fit's Lambda
    flattens out (exp(L(0)) = 7.6e8, where the true Lambda grows as 1/mu: 9e19 at the
    renderer's n.l floor 1e-20), so 1/n.l would no longer be cancelled and f would grow as
    1/n.l: a light's albedo at n.l = 1e-20 came out ~5e7. With both cosines at one floor, f
    is bounded and f(l, v) = f(v, l) holds at the clamps too; f (n.l) still goes to 0.

    Precision: every factor is positive and finite in float32 (both cosines >= 1e-4 and
    Lambda <= 7.7e8 give a denominator in [4e-8, 7e9]), so V needs no other guard: no Inf,
    no NaN. Written as one reciprocal of a product, not G2 times 1/(4 n.l n.v)."""
    NoL, NoV = np.maximum(_f64(NoL), MIN_N_DOT_V), _f64(NoV)
    lam = 1.0 + Lambda_charlie(NoL, alpha) + Lambda_charlie(NoV, alpha)
    return 1.0 / (4.0 * (NoL * NoV) * lam)


# Panels of Lambda_charlie_quadrature, as fractions of the cut t* = sin(theta_v): graded
# toward n.m = 0, where Charlie's lobe peaks (width ~ sqrt(alpha) in n.m), and toward t*,
# where the integrand has a square-root branch point.
_LAMBDA_PANELS = np.array(
    [0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3, 0.6, 0.9, 0.99, 0.999, 0.9999,
     1.0 - 1e-6, 1.0]
)  # fmt: skip


def Lambda_charlie_quadrature(mu: float, alpha: float, nodes: int = 48) -> float:
    """The exact Smith Lambda of the Charlie NDF at n.v = mu, by quadrature of its definition
    (RTR4 §9.7: with G1 = 1/(1 + Lambda), integral of G1 D(m) (v.m)+ dm = n.v), the reference
    Estevez & Kulla's fit is measured against.

    Since integral of D(m) (v.m) dm = n.v (projected area), Lambda(v) n.v = integral of
    D(m) (v.m)- dm, the back-facing part alone (no cancellation as Lambda -> 0 at mu -> 1).
    With t = n.m, s = sqrt(1 - t^2), A = mu t and B = sin(theta_v) s, v.m = A + B cos(phi),
    and the azimuth integral is closed: integral over phi of (-(A + B cos phi))+ =
    2 (sqrt(B^2 - A^2) - A arccos(A/B)) where A < B, i.e. t < t* = sin(theta_v), else 0 (derived
    here; checked against a direction-space rule in tests/test_sheen.py). What remains,
    Lambda = (1/mu) integral_0^t* D(t) (that) dt, is composite Gauss-Legendre (``nodes`` per
    panel) on _LAMBDA_PANELS."""
    mu = float(mu)
    if mu >= 1.0:
        return 0.0
    sv = np.sqrt(1.0 - mu * mu)
    total = 0.0
    for lo, hi in zip(_LAMBDA_PANELS[:-1] * sv, _LAMBDA_PANELS[1:] * sv, strict=True):
        t, w = gauss_legendre(lo, hi, nodes)
        A = mu * t
        B = sv * np.sqrt(1.0 - t * t)
        h = 2.0 * (np.sqrt(np.maximum(B * B - A * A, 0.0)) - A * np.arccos(np.minimum(A / B, 1.0)))
        D = (2.0 + 1.0 / alpha) * (0.5 / PI) * np.exp(np.log1p(-t * t) / (2.0 * alpha))
        total += float(np.sum(w * D * h))
    return total / mu


def D_sheen_selected(sheen: str, n: np.ndarray, h: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The sheen NDF of the chosen model (not "none"); "charlie_smith" shares Charlie's."""
    if sheen == "ashikhmin":
        return D_ashikhmin(n, h, alpha)
    return D_charlie(n, h, alpha)


def V_sheen_selected(sheen: str, NoL: np.ndarray, NoV: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The sheen visibility of the chosen model: Charlie's Smith G2 for "charlie_smith",
    Neubelt's V for the others."""
    if sheen == "charlie_smith":
        return V_charlie_smith(NoL, NoV, alpha)
    return V_neubelt(NoL, NoV)


def f_sheen(
    sheen: str,
    sheen_color: np.ndarray,
    alpha: np.ndarray,
    n: np.ndarray,
    h: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
) -> np.ndarray:
    """f_sheen = sheen_color D(h) V(n.l, n.v), (..., 3)."""
    dv = D_sheen_selected(sheen, n, h, alpha) * V_sheen_selected(sheen, NoL, NoV, alpha)
    return _f64(sheen_color) * dv[..., None]


# --- the layer over the base: glTF KHR_materials_sheen's albedo scaling ----------------------


def sheen_scaling(sheen_color: np.ndarray, E_l: np.ndarray, E_v: np.ndarray) -> np.ndarray:
    """1 - max(sheen_color) max(E(n.l), E(n.v)), clamped to [0, 1]: the energy the sheen
    leaves to the base. glTF writes min(1 - c E(n.v), 1 - c E(n.l)), the same number; the max
    over both directions keeps f(l, v) = f(v, l). The clamp at 0 is ours: with Neubelt's V,
    Charlie's albedo exceeds 1 toward grazing for sheen_roughness below ~0.5 (8.8 at the
    roughness floor and n.v = 0; docs/cloth.md), and with Estevez & Kulla's fitted Smith
    Lambda below ~0.26 (4.4 at the floor), where the unclamped scaling would turn the base
    negative."""
    c = np.max(_f64(sheen_color), axis=-1)
    E = np.maximum(_f64(E_l), _f64(E_v))
    return np.clip(1.0 - c * E, 0.0, 1.0)


# --- the directional albedo E(mu, r) of the sheen lobe: quadrature and its table ------------

# Quadrature of one albedo: cosine_rule(QUAD_MU, QUAD_PHI) over l. The lobes are broad in l
# (Charlie's narrowest, at the roughness floor, is ~3 degrees wide in theta_h but spread over
# the whole azimuth); against (256, 512) the difference is below 2e-8 on the table's nodes
# (tests/test_sheen.py checks a few).
QUAD_MU = 128
QUAD_PHI = 256
# The shipped table's size (n_r = n_mu): 64 x 64 nodes, the multiple-scattering table's
# grids (app/reference/multiscatter.py mu_grid, roughness_grid: mu = x^4, r = floor +
# 0.955 y^2), channel 0 Charlie, channel 1 Ashikhmin (both with Neubelt's V), channel 2
# Charlie with its Smith Lambda (appended: the first two are bit-identical to the two-channel
# table they extend).
TABLE_SIZE = SHEEN_TABLE_SIZE
TABLE_MODELS = ("charlie", "ashikhmin", "charlie_smith")  # channel order


def sheen_albedo(sheen: str, mu: float, sheen_roughness: float, rule=None) -> float:
    """E(mu, r) = integral of D(h) V(n.l, n.v) (n.l)+ dl with v at n.v = mu (sheen_color 1),
    by quadrature; n.v enters V clamped at MIN_N_DOT_V as in the renderer."""
    l, w = rule if rule is not None else cosine_rule(QUAD_MU, QUAD_PHI)
    mu = float(np.clip(mu, 0.0, 1.0))
    v = np.array([np.sqrt(1.0 - mu * mu), 0.0, mu])
    hv = l + v
    h = hv / np.linalg.norm(hv, axis=-1, keepdims=True)
    NoL = l[:, 2]
    alpha = sheen_alpha(sheen_roughness)
    f = D_sheen_selected(sheen, N, h, alpha) * V_sheen_selected(
        sheen, NoL, max(mu, MIN_N_DOT_V), alpha
    )
    return float(np.sum(f * NoL * w))


def compute_table(size: int = TABLE_SIZE) -> np.ndarray:
    """E on mu_grid x roughness_grid for every model, float64 (size, size, 3)."""
    rule = cosine_rule(QUAD_MU, QUAD_PHI)
    mus, rs = mu_grid(size), roughness_grid(size)
    return np.stack(
        [
            np.array([[sheen_albedo(model, m, r, rule) for m in mus] for r in rs])
            for model in TABLE_MODELS
        ],
        axis=-1,
    )


def generate(size: int = TABLE_SIZE) -> Path:
    """Compute the table and write it to app/common/data (scripts/sheen_tables.py)."""
    path = sheen_table_path(size)
    _save(path, compute_table(size).astype(np.float32))
    return path


@cache
def load_table(size: int = TABLE_SIZE) -> np.ndarray:
    """The shipped float32 (size, size, 3) table, read-only."""
    return read_sheen_table(size)


def _lerp_cell(s: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid coordinate s in [0, n - 1] -> cell index in [0, n - 2] and the fraction."""
    i = np.minimum(s.astype(np.int64), n - 2)
    return i, s - i


def sheen_E(
    table: np.ndarray, sheen: str, mu: np.ndarray, sheen_roughness: np.ndarray
) -> np.ndarray:
    """E(mu, r) from the table: bilinear in (sqrt(sqrt(mu)), sqrt((r - floor)/(1 - floor)))
    with (1 - t) a + t b, the GLSL's sums (glsl/brdf/sheen.glsl sheen_E)."""
    channel = TABLE_MODELS.index(sheen)
    n_r, n_mu = table.shape[:2]
    mu, r = np.broadcast_arrays(_f64(mu), _f64(sheen_roughness))
    j, tx = _lerp_cell(mu_coord(mu, n_mu), n_mu)
    i, ty = _lerp_cell(r_coord(r, n_r), n_r)
    t = np.asarray(table, np.float64)[..., channel]
    lo = (1.0 - tx) * t[i, j] + tx * t[i, j + 1]
    hi = (1.0 - tx) * t[i + 1, j] + tx * t[i + 1, j + 1]
    return (1.0 - ty) * lo + ty * hi
