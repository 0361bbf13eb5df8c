"""Twin of glsl/brdf/multiscatter.glsl: Kulla-Conty multiple-scattering compensation.

Kulla & Conty 2017, "Revisiting Physically Based Shading at Imageworks" (SIGGRAPH course).
The single-scattering GGX specular (app.reference.specular.f_spec_GGX) loses the light that
bounces more than once between microfacets. With F = 1 its directional albedo is

    E(mu, r) = integral of f_spec(l, v) (n.v) dv,   mu = n.l, alpha = max(r, 0.045)^2,

and its cosine-weighted average is E_avg(r) = 2 integral_0^1 E(mu) mu dmu. The added lobe

    f_ms = (1 - E(n.l)) (1 - E(n.v)) / (pi (1 - E_avg))

has directional albedo exactly 1 - E(n.l), so f_spec + f_ms reflects everything when F = 1;
for a coloured F0 it is scaled by F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), the sum over
bounces of a light path that meets Fresnel F_avg at every bounce.

The table
---------
E is tabulated by deterministic quadrature (app.reference.quadrature.reflected_rule) on

* mu_j = (j / (n_mu - 1))^4, j = 0 .. n_mu - 1, and
* r_i = 0.045 + (1 - 0.045) (i / (n_r - 1))^2 (roughness below the floor is the floor),

end points included, nodes crowded toward grazing and toward smooth surfaces. That is where
E changes fastest: at r = 1, E = 1 - mu ln(1 + 1/mu) has an infinite slope at mu = 0, and
for small r, E has a dip of width ~alpha next to mu = 0 (E = 0.92 at mu = 1e-3 for
r = 0.045), whose place moves with alpha = r^2. Largest furnace residual of the compensated
BRDF over r in [0, 1] and theta up to 89.99 degrees at 32 x 32, same quadrature and E_avg:
10.7% with mu and r uniform (1.05% already at 89 degrees), 2.0% with mu = x^2 and r uniform
from the floor, 0.32% with these grids (tests/test_multiscatter.py; docs/diffuse-and-
multiscatter.md). Both coordinates, x = sqrt(sqrt(mu)) and sqrt((r - 0.045)/0.955), need
only sqrt in the GLSL, not pow (exp2(y log2 x), whose error grows with |y log2 x|).

E(0) = 1, the limit of the exact BRDF: as mu -> 0, f_spec (n.v) -> D(h)/(2 alpha)
(V -> 1/(2 alpha n.v)), and the integral over v becomes (2/alpha) times the projected area
of the microsurface seen from the horizon, (1 + Lambda(mu)) mu -> alpha/2 (Smith; seed
section 7). Elsewhere the table holds E of f_spec_GGX as the renderer evaluates it, n.v
clamped at MIN_N_DOT_V = 1e-4, which lowers E at the most grazing nodes (by 4.6e-5 at
mu = 1e-6 for r = 1, against the closed form 1 - mu ln(1 + 1/mu)).

E_avg(r) is integrated separately and accurately (24-point Gauss-Legendre in x = sqrt(mu):
E_avg = 4 int_0^1 E(x^2) x^3 dx; error < 1e-9 against 64 points), not summed over the grid.

What is stored (float32, shape (n_r, n_mu, 2), also the RG32F texture's texels, x = mu
index, y = r index) is the energy LOSS: ``table[i, j] = (1 - E(mu_j, r_i), 1 - E_avg(r_i))``.
A float32 E near 1 keeps only ~6e-8 absolute, i.e. the loss of a smooth surface (2.7e-5 on
average at the roughness floor, 4.4e-6 at normal incidence) to 1-3 digits; the loss keeps 7.

Interpolation is bilinear in (sqrt(sqrt(mu)), sqrt((r - 0.045)/0.955)) on the stored values,
done by hand in the GLSL with texelFetch and identically here in float64, so GLSL and twin
differ by float32 rounding only. Hardware bilinear filtering is not used: GPU texture units
weigh texels with fixed-point fractions (8 fractional bits on NVIDIA, per the CUDA
programming guide), an error of up to 2e-3 of a cell's difference. (On this machine's
llvmpipe, R32F filtering measured exact; the project does not rely on either.)
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from functools import cache
from pathlib import Path

import numpy as np

from app.common.models import Model
from app.common.tables import DEFAULT_SIZE, MS_FORMS, ms_form, read_ms_table, table_path
from app.reference import fresnel, masking
from app.reference.constants import MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS, PI
from app.reference.ndf import D_GGX
from app.reference.quadrature import N, directional_albedo, gauss_legendre, reflected_rule
from app.reference.specular import G2_selected, f_spec_GGX

# Quadrature of one albedo: reflected_rule(l, alpha, QUAD_PSI, QUAD_PHI). Against a
# (24, 96) rule the difference is at most 1.3e-6 at the two most grazing nodes
# (mu <= 2e-5), 4e-7 for mu >= 1e-4 and 7e-8 for mu >= 4e-3; the azimuthal resolution
# limits it (more psi nodes change nothing).
QUAD_PSI = 8
QUAD_PHI = 32
AVG_NODES = 24  # Gauss-Legendre nodes in sqrt(mu) for E_avg

# Below every real 1 - E_avg of the table (2.7e-5 at the roughness floor): it only keeps a
# table whose row loses nothing (so that 1 - E is 0 too) from dividing 0 by 0.
MS_MIN_LOSS_AVG = 1e-6


# --- the grids ---------------------------------------------------------------------------


def mu_grid(n_mu: int) -> np.ndarray:
    """The table's mu = n.l nodes, (j/(n_mu - 1))^4: crowded toward grazing."""
    return (np.arange(n_mu, dtype=np.float64) / (n_mu - 1)) ** 4


def roughness_grid(n_r: int) -> np.ndarray:
    """The table's perceptual roughness nodes, 0.045 + 0.955 (i/(n_r - 1))^2, ends exact."""
    t = np.arange(n_r, dtype=np.float64) / (n_r - 1)
    r = MIN_PERCEPTUAL_ROUGHNESS + (1.0 - MIN_PERCEPTUAL_ROUGHNESS) * t * t
    r[0], r[-1] = MIN_PERCEPTUAL_ROUGHNESS, 1.0
    return r


def mu_coord(mu: np.ndarray, n_mu: int) -> np.ndarray:
    """Column coordinate in [0, n_mu - 1] of mu: sqrt(sqrt(mu)) (n_mu - 1), as the GLSL."""
    return np.sqrt(np.sqrt(np.clip(np.asarray(mu, np.float64), 0.0, 1.0))) * (n_mu - 1)


# The GLSL's MIN_PERCEPTUAL_ROUGHNESS is the float32 nearest 0.045, i.e. 0.045 + 1.8e-9.
# The row coordinate sqrt((r - floor)/(1 - floor)) has an infinite slope at the floor, so
# the twin subtracts that same value: with the float64 0.045, r = float32(0.045) would sit
# 1.3e-3 of a cell above the floor row instead of on it (a 1e-4 relative change of 1 - E).
_FLOOR_GLSL = float(np.float32(MIN_PERCEPTUAL_ROUGHNESS))


def r_coord(r: np.ndarray, n_r: int) -> np.ndarray:
    """Row coordinate in [0, n_r - 1] of a perceptual roughness (floored), as the GLSL."""
    r = np.clip(np.asarray(r, np.float64), _FLOOR_GLSL, 1.0)
    u = (r - _FLOOR_GLSL) / (1.0 - _FLOOR_GLSL)
    return np.sqrt(u) * (n_r - 1)


# --- the quadrature ----------------------------------------------------------------------


# mu = 0 of a form other than the height-correlated one is integrated at this mu: the
# rule needs n.l > 0, and only the height-correlated limit (1) is known in closed form.
# (The separable form's E(0) is below 1: G1(v) multiplies the height-correlated limit.)
GRAZING_MU = 1e-8


def form_model(form: str) -> Model:
    """The GGX model whose G2 the table ``form`` (MS_FORMS) integrates."""
    if form not in MS_FORMS:
        raise ValueError(f"no multiple-scattering table for the G2 form {form!r}")
    for correlation in ("exp", "rational"):
        if form.endswith(f"_{correlation}"):
            return Model(g2=form.removesuffix(f"_{correlation}"), correlation=correlation)
    return Model(g2=form)


def f_spec_GGX_form(form: str, alpha: float, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """D G2 / (4 n.l n.v) with F = 1, GGX D and the G2 of ``form`` from the GGX Lambdas
    (the renderer's Lambda path, app.reference.specular.G2_selected; Hammon's fit as the
    fused V = G2/(4 n.l n.v) the renderer evaluates), n.v clamped at
    MIN_N_DOT_V as the renderer clamps it: (M,)."""
    n = np.broadcast_to(N, v.shape)
    NoL = float(l @ N)
    NoV = np.clip(v @ N, MIN_N_DOT_V, 1.0)
    h = l + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    if form == "hammon":  # the renderer's fused V of Hammon's fit
        return D_GGX(n, h, alpha) * masking.V_hammon_GGX(NoL, NoV, alpha)
    G2 = G2_selected(
        form_model(form),
        masking.Lambda_GGX(NoV, alpha),
        masking.Lambda_GGX(np.full_like(NoV, NoL), alpha),
        n,
        np.broadcast_to(l, v.shape),
        v,
    )
    return D_GGX(n, h, alpha) * G2 / (4.0 * NoL * NoV)


def single_scatter_albedo(
    mu: float, perceptual_roughness: float, form: str = "height_correlated"
) -> float:
    """E(mu, r): directional albedo with F = 1 of the single-scattering GGX specular with
    the G2 of ``form`` (MS_FORMS), by quadrature. The height-correlated one is
    f_spec_GGX's (the renderer's fused V) and returns the limit 1 at mu = 0 (see the module
    docstring); the others integrate mu = 0 at GRAZING_MU.
    """
    hc = form == "height_correlated"
    if mu <= 0.0:
        if hc:
            return 1.0
        mu = GRAZING_MU
    r = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    alpha = r * r
    l = np.array([np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    v, w = reflected_rule(l, alpha, QUAD_PSI, QUAD_PHI)
    f = f_spec_GGX(1.0, alpha, N, l, v) if hc else f_spec_GGX_form(form, alpha, l, v)[:, None]
    return float(directional_albedo(f, v, w)[0])


def average_albedo(perceptual_roughness: float, form: str = "height_correlated") -> float:
    """E_avg(r) = 2 int_0^1 E(mu) mu dmu = 4 int_0^1 E(x^2) x^3 dx (Gauss-Legendre in x)."""
    x, w = gauss_legendre(0.0, 1.0, AVG_NODES)
    E = np.array([single_scatter_albedo(xi * xi, perceptual_roughness, form) for xi in x])
    return float(4.0 * np.sum(w * x**3 * E))


def compute_tables(
    n_mu: int, n_r: int, rows: Sequence[int] | None = None, form: str = "height_correlated"
) -> tuple[np.ndarray, np.ndarray]:
    """E (n_r, n_mu) on mu_grid x roughness_grid and E_avg (n_r,) of the G2 ``form``
    (MS_FORMS), in float64: the same generator for every form, only the G2 differs.

    ``rows`` selects some roughness rows only (the tests check the shipped table that way:
    the whole 64 x 64 table takes ~10 s).
    """
    mus = mu_grid(n_mu)
    rs = roughness_grid(n_r)
    if rows is not None:
        rs = rs[list(rows)]
    E = np.array([[single_scatter_albedo(m, r, form) for m in mus] for r in rs])
    E_avg = np.array([average_albedo(r, form) for r in rs])
    return E, E_avg


def pack_table(E: np.ndarray, E_avg: np.ndarray) -> np.ndarray:
    """The stored layout: float32 (n_r, n_mu, 2) of (1 - E, 1 - E_avg)."""
    E = np.asarray(E, np.float64)
    loss_avg = np.broadcast_to((1.0 - np.asarray(E_avg, np.float64))[:, None], E.shape)
    return np.stack([1.0 - E, loss_avg], axis=-1).astype(np.float32)


# --- files (where they live: app/common/tables.py) -------------------------------------


def _save(path: Path, table: np.ndarray) -> None:
    """Write atomically, so parallel processes never read half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npy.tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.save(f, table)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def generate(size: int, form: str = "height_correlated") -> Path:
    """Compute the size x size table of the G2 ``form`` and write it where load_table
    looks for it."""
    path = table_path(size, form)
    _save(path, pack_table(*compute_tables(size, size, form=form)))
    return path


@cache
def load_table(size: int = DEFAULT_SIZE, form: str = "height_correlated") -> np.ndarray:
    """The float32 (size, size, 2) loss table of the G2 ``form`` (MS_FORMS; read-only),
    computed and cached on first use.

    The shipped sizes (32, 64, 128) are read from app/common/data; other sizes come from
    the cache directory, or are computed (seconds to minutes) and stored there.
    """
    if size < 2:
        raise ValueError(f"a table needs at least 2 nodes per axis, not {size}")
    path = table_path(size, form)
    if not path.is_file():
        _save(path, pack_table(*compute_tables(size, size, form=form)))
    return read_ms_table(size, form)


@cache
def load_tables(size: int = DEFAULT_SIZE, forms: tuple[str, ...] = MS_FORMS) -> np.ndarray:
    """The forms' tables, float32 (len(MS_FORMS), size, size, 2) in MS_FORMS order, as the
    renderer's texture stacks them (read-only): what ``RenderOptions.ms_table`` and the
    twin's ``ms_table`` arguments take. A form left out of ``forms`` is a block of NaN, so
    a material with that G2 shades NaN instead of another G2's compensation (the bench's
    table sizes, which only the height-correlated G2 uses, need not compute the rest)."""
    nan = np.full((size, size, 2), np.nan, np.float32)
    stack = np.stack([load_table(size, f) if f in forms else nan for f in MS_FORMS])
    stack.setflags(write=False)
    return stack


def table_for(model: Model, tables: np.ndarray | None = None) -> np.ndarray:
    """The (n, n, 2) table of ``model``'s G2 (``ms_form``): from the stack ``tables``
    (load_tables), or the shipped default size's where None; a single (n, n, 2) table is
    taken as it is (the caller chose it)."""
    form = ms_form(model.g2, model.correlation)
    if tables is None:
        return load_table(DEFAULT_SIZE, form)
    tables = np.asarray(tables)
    return tables[MS_FORMS.index(form)] if tables.ndim == 4 else tables


# --- the shading functions (twins of the GLSL) -------------------------------------------


def _cell(s: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid coordinate s in [0, n - 1] -> (cell index i in [0, n - 2], fraction t)."""
    i = np.minimum(np.floor(s), n - 2).astype(np.intp)
    return i, s - i


def grid_bilinear(table: np.ndarray, mu: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Every channel of a table on these grids (n_r, n_mu, C) at (mu, r), bilinear in the
    grid coordinates on its float32 values: (..., C). The split-sum DFG table
    (app/reference/ibl.py) shares the grids and this look-up."""
    t64 = np.asarray(table, np.float64)
    n_r, n_mu = t64.shape[:2]
    mu, r = np.broadcast_arrays(np.asarray(mu, np.float64), np.asarray(r, np.float64))
    j, tx = _cell(mu_coord(mu, n_mu), n_mu)
    i, ty = _cell(r_coord(r, n_r), n_r)
    tx, ty = tx[..., None], ty[..., None]
    lo = (1.0 - tx) * t64[i, j] + tx * t64[i, j + 1]
    hi = (1.0 - tx) * t64[i + 1, j] + tx * t64[i + 1, j + 1]
    return (1.0 - ty) * lo + ty * hi


def ms_loss(table: np.ndarray, mu: np.ndarray, r: np.ndarray) -> np.ndarray:
    """1 - E(mu, r), bilinear in the grid coordinates on the table's float32 values."""
    return grid_bilinear(table, mu, r)[..., 0]


def ms_loss_avg(table: np.ndarray, r: np.ndarray) -> np.ndarray:
    """1 - E_avg(r), linear in the row coordinate on the table's float32 values."""
    t64 = np.asarray(table, np.float64)
    i, ty = _cell(r_coord(r, t64.shape[0]), t64.shape[0])
    return (1.0 - ty) * t64[i, 0, 1] + ty * t64[i + 1, 0, 1]


def ms_E(table: np.ndarray, mu: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Kulla & Conty 2017: E(mu, r), the single-scattering albedo of f_spec_GGX with F = 1."""
    return 1.0 - ms_loss(table, mu, r)


def ms_E_avg(table: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Kulla & Conty 2017: E_avg(r) = 2 int E(mu) mu dmu."""
    return 1.0 - ms_loss_avg(table, r)


def F_avg_schlick(F0: np.ndarray) -> np.ndarray:
    """Hemispherical average 2 int F(mu) mu dmu of Schlick's F: F0 + (1 - F0)/21.

    Kulla & Conty 2017; 2 int_0^1 (1 - mu)^5 mu dmu = 2 B(2, 6) = 1/21.
    """
    F0 = np.asarray(F0, np.float64)
    return F0 + (1.0 - F0) / 21.0


# The nodes of F_avg's quadrature: the midpoint rule in mu on F_AVG_NODES cells.
F_AVG_NODES = 16


def _F_avg_nodes() -> np.ndarray:
    return (np.arange(F_AVG_NODES) + 0.5) / F_AVG_NODES


def F_avg_conductor(eta: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Kulla & Conty 2017: F_avg = 2 int_0^1 F(mu) mu dmu of the exact conductor Fresnel
    (index eta + i k, (..., 3)), by the midpoint rule on 16 cells (as the GLSL), (..., 3)."""
    eta = np.asarray(eta, np.float64)[..., None, :]
    k = np.asarray(k, np.float64)[..., None, :]
    mu = _F_avg_nodes()
    F = fresnel.F_conductor(eta, k, mu)  # (..., 16, 3)
    return np.sum(F * mu[:, None], axis=-2) * (2.0 / F_AVG_NODES)


def F_avg_dielectric(eta: np.ndarray | float) -> np.ndarray:
    """The same average of the exact dielectric Fresnel (relative index eta), (...)."""
    eta = np.asarray(eta, np.float64)[..., None]
    mu = _F_avg_nodes()
    F = np.asarray(fresnel.F_dielectric(eta, mu), np.float64)  # (..., 16)
    return np.sum(F * mu, axis=-1) * (2.0 / F_AVG_NODES)


def f_ms_kulla_conty(
    table: np.ndarray, F0: np.ndarray, r: np.ndarray, NoL: np.ndarray, NoV: np.ndarray
) -> np.ndarray:
    """The lobe with Schlick's F: ``f_ms_kulla_conty_F_avg`` of F0 + (1 - F0)/21."""
    return f_ms_kulla_conty_F_avg(table, F_avg_schlick(F0), r, NoL, NoV)


def f_ms_kulla_conty_F_avg(
    table: np.ndarray, F_avg: np.ndarray, r: np.ndarray, NoL: np.ndarray, NoV: np.ndarray
) -> np.ndarray:
    """Kulla & Conty 2017: the added lobe (1 - E(n.l))(1 - E(n.v)) / (pi (1 - E_avg)) times
    F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), F_avg the hemispherical average of the
    material's Fresnel; returns (..., 3)."""
    loss_l = ms_loss(table, NoL, r)
    loss_v = ms_loss(table, NoV, r)
    loss_avg = ms_loss_avg(table, r)
    F_avg = np.asarray(F_avg, np.float64)
    la = loss_avg[..., None]
    colour = F_avg * F_avg * (1.0 - la) / (1.0 - F_avg * la)
    lobe = loss_l * loss_v / (PI * np.maximum(loss_avg, MS_MIN_LOSS_AVG))
    return colour * lobe[..., None]


# --- command line ------------------------------------------------------------------------
