"""Fit the linearly transformed cosine (LTC) table of the project's GGX lobe, in float64.

Heitz, Dupuy, Hill and Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
Transformed Cosines": a clamped cosine D_cos(w_o) = max(z_o, 0) / pi, transformed by a 3 x 3
matrix M (w = M w_o / |M w_o|), becomes the distribution

    D_o(w) = D_cos(w_o) |det M^-1| / |M^-1 w|^3,   w_o = M^-1 w / |M^-1 w|,

whose integral over a polygon P is the clamped-cosine integral over M^-1 P (closed form).
Per cell (perceptual roughness r, view cosine n.v) this fits M^-1 so that D_o matches the
normalised lobe f(l, v) (n.l) / n_D of the GGX specular BRDF with F = 1 as the project
evaluates it (D_GGX, the height-correlated Smith G2 of V_height_correlated_GGX), and
records the magnitudes (by the DFG table's quadrature, app/reference/ibl.py dfg_terms):

    n_D = integral f (n.l) dl                 (the lobe's albedo with F = 1)
    f_b = integral f (1 - l.h)^5 (n.l) dl     (Schlick's part: F0 (n_D - f_b) + f_b)

The isotropic M^-1 has four free entries in the frame (x along v's tangent, z = n):
[[a, 0, b], [0, c, 0], [d, 0, 1]] (its scale does not change D_o). The error minimised is
the paper's: the integral of |D_o - D_target|^3 over the sphere, estimated with a fixed
set of stratified samples drawn from both distributions (balance heuristic), so the
objective is smooth for Nelder-Mead; each cell starts from its fitted neighbour (rough to
smooth, then along n.v), as the paper describes.

Writes app/common/data/ltc_ggx_<N>.npy: (N, N, 8) float64, axis 0 the perceptual roughness
r_i = MIN + (1 - MIN) i / (N - 1), axis 1 t_j = j / (N - 1) with n.v = 1 - t_j^2 (floored
at 1e-3); channels a, b, c, d, n_D, f_b, the fit's L1 error integral |D_o - D_target|, 0.

    python scripts/ltc_tables.py [--size 32] [--jobs 4] [--refit ROW ...]
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.reference.area_lights import LTC_MIN_NOV, ltc_table_path
from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.ibl import dfg_terms
from app.reference.masking import V_height_correlated_GGX

REFIT_ROWS = 2  # the smoothest rows, fitted again from their rougher neighbours
SAMPLES = 32  # strata per side for each of the two sampling strategies


def _strata(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A fixed, jittered n x n stratification of the unit square (the same every call)."""
    rng = np.random.default_rng(12345)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    u = (i.ravel() + rng.random(n * n)) / n
    w = (j.ravel() + rng.random(n * n)) / n
    return u, w


U1, U2 = _strata(SAMPLES)


def ggx_target(l: np.ndarray, v: np.ndarray, alpha: float) -> np.ndarray:
    """f(l, v) (n.l) of the GGX lobe with F = 1 (n = +z), zero below the horizon."""
    nol = l[..., 2]
    h = l + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    noh = h[..., 2]
    a2 = alpha * alpha
    d = noh * noh * (a2 - 1.0) + 1.0
    D = a2 / (np.pi * d * d)
    with np.errstate(invalid="ignore", divide="ignore"):
        Vis = V_height_correlated_GGX(np.maximum(nol, 0.0), v[2], alpha)
    out = D * Vis * nol
    return np.where((nol > 0.0) & (noh > 0.0), out, 0.0)


def sample_ggx(v: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Directions l reflected about GGX normals (pdf D (n.h) / (4 v.h)) and their pdf."""
    tan2 = alpha * alpha * U1 / np.maximum(1.0 - U1, 1e-300)
    cos_t = 1.0 / np.sqrt(1.0 + tan2)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * np.pi * U2
    h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)
    voh = h @ v
    l = 2.0 * voh[:, None] * h - v
    a2 = alpha * alpha
    d = cos_t * cos_t * (a2 - 1.0) + 1.0
    pdf = a2 / (np.pi * d * d) * cos_t / (4.0 * np.maximum(voh, 1e-300))
    return l, np.where(voh > 0.0, pdf, 0.0)


def minv_of(p: np.ndarray) -> np.ndarray:
    a, b, c, d = p
    return np.array([[a, 0.0, b], [0.0, c, 0.0], [d, 0.0, 1.0]])


def ltc_pdf(l: np.ndarray, minv: np.ndarray) -> np.ndarray:
    """D_o(l) of the LTC with inverse matrix ``minv``."""
    lo = l @ minv.T
    length = np.linalg.norm(lo, axis=-1)
    det = abs(np.linalg.det(minv))
    return np.maximum(lo[:, 2] / length, 0.0) / np.pi * det / length**3


def sample_ltc(minv: np.ndarray) -> np.ndarray:
    """Directions drawn from the LTC (cosine samples transformed by M)."""
    r = np.sqrt(U1)
    phi = 2.0 * np.pi * U2
    wo = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - U1))], -1)
    w = wo @ np.linalg.inv(minv).T
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


def magnitudes(v: np.ndarray, alpha: float) -> tuple[float, float]:
    """(n_D, f_b) by importance sampling the GGX normals (weight f (n.l) / pdf)."""
    l, pdf = sample_ggx(v, alpha)
    f = ggx_target(l, v, alpha)
    h = l + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    loh = np.clip(np.sum(l * h, axis=-1), 0.0, 1.0)
    w = np.where(pdf > 0.0, f / np.where(pdf > 0.0, pdf, 1.0), 0.0)
    return float(np.mean(w)), float(np.mean(w * (1.0 - loh) ** 5))


@np.errstate(invalid="ignore", divide="ignore")
def fit_error(p: np.ndarray, v: np.ndarray, alpha: float, n_d: float, lg, pg) -> float:
    """integral |D_o - D_t|^3 over the sphere, both strategies' samples (balance)."""
    minv = minv_of(p)
    if abs(np.linalg.det(minv)) < 1e-12 or p[0] <= 0.0 or p[2] <= 0.0:
        return 1e30
    return _balanced_error(minv, v, alpha, n_d, lg, pg, 3)


def _ggx_pdf(l: np.ndarray, v: np.ndarray, alpha: float) -> np.ndarray:
    h = l + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    noh = h[:, 2]
    voh = h @ v
    a2 = alpha * alpha
    d = noh * noh * (a2 - 1.0) + 1.0
    pdf = a2 / (np.pi * d * d) * noh / (4.0 * np.maximum(voh, 1e-300))
    return np.where((noh > 0.0) & (voh > 0.0) & (l[:, 2] > 0.0), pdf, 0.0)


@np.errstate(invalid="ignore", divide="ignore")
def l1_error(p: np.ndarray, v: np.ndarray, alpha: float, n_d: float, lg, pg) -> float:
    """integral |D_o - D_t| (0: exact, 2: disjoint), the fit's quality per cell."""
    return _balanced_error(minv_of(p), v, alpha, n_d, lg, pg, 1)


def _balanced_error(
    minv: np.ndarray, v: np.ndarray, alpha: float, n_d: float, lg, pg, power: int
) -> float:
    """integral |D_o - D_t|^power over the sphere, estimated from both strategies' samples
    (the LTC's, drawn here, and the GGX's ``lg`` with their densities ``pg``) by the
    balance heuristic: each sample weighs 1 / (D_o + pdf_GGX)."""
    lo = sample_ltc(minv)
    total = 0.0
    for l, p_other in ((lo, None), (lg, pg)):
        d_o = ltc_pdf(l, minv)
        d_t = ggx_target(l, v, alpha) / n_d
        pdf_g = p_other if p_other is not None else _ggx_pdf(l, v, alpha)
        denom = d_o + pdf_g
        error = np.abs(d_o - d_t)
        if power != 1:
            error = error**power
        total += float(np.sum(np.where(denom > 0.0, error / denom, 0.0)))
    return total / len(U1)


def row_roughness(i: int, size: int) -> float:
    """The perceptual roughness of table row ``i`` of ``size``: MIN_PERCEPTUAL_ROUGHNESS
    to 1 in equal steps."""
    return MIN_PERCEPTUAL_ROUGHNESS + (1.0 - MIN_PERCEPTUAL_ROUGHNESS) * i / (size - 1)


def cell_view(j: int, size: int) -> tuple[float, np.ndarray]:
    """Column ``j``'s n.v (its sqrt(1 - n.v) in equal steps, floored at LTC_MIN_NOV) and
    the view direction in the normal's frame (in the x-z plane)."""
    t = j / (size - 1)
    nov = max(1.0 - t * t, LTC_MIN_NOV)
    return nov, np.array([np.sqrt(1.0 - nov * nov), 0.0, nov])


def fit_cell(
    guess: np.ndarray, v: np.ndarray, alpha: float, n_d: float
) -> tuple[np.ndarray, float]:
    """One cell's fitted (a, b, c, d) of M^-1 from ``guess`` (Nelder-Mead on ``fit_error``
    over the GGX samples of view ``v``, roughness ``alpha``, the lobe normalised by its
    albedo ``n_d``) and the fit's ``l1_error``."""
    lg, pg = sample_ggx(v, alpha)
    res = minimize(
        fit_error, guess, args=(v, alpha, n_d, lg, pg), method="Nelder-Mead",
        options={"xatol": 1e-6, "fatol": 0.0, "maxfev": 600},
    )  # fmt: skip
    return res.x, l1_error(res.x, v, alpha, n_d, lg, pg)


def fit_rows(size: int, rows: range) -> np.ndarray:
    """The table's ``rows`` (roughness indices), rough to smooth; the first row's n.v = 1
    cell starts from M^-1 = diag(1 / (2 alpha), 1 / (2 alpha), 1) (the reflected lobe is
    about twice as wide as the NDF's alpha), every other cell from its fitted neighbour."""
    table = np.zeros((size, size, 8))
    start_row = None
    for i in reversed(rows):  # rough to smooth
        r = row_roughness(i, size)
        alpha = r * r
        if start_row is None:
            k = min(1.0, 1.0 / (2.0 * alpha))
            start_row = np.array([k, 0.0, k, 0.0])
        guess = start_row
        for j in range(size):
            nov, v = cell_view(j, size)
            A, B = dfg_terms(nov, r)  # the project's quadrature (app/reference/ibl.py)
            n_d, f_b = A + B, B
            p, table[i, j, 6] = fit_cell(guess, v, alpha, n_d)
            table[i, j, :4] = p
            table[i, j, 4:6] = n_d, f_b
            guess = p
            if j == 0:
                start_row = p
        print(f"r {r:.3f}: worst L1 {table[i, :, 6].max():.3f}", flush=True)
    return table


def refit_rows(table: np.ndarray, rows: list[int]) -> None:
    """Fit ``rows`` again (descending), each cell from the cell of the next rougher row with
    a, b, c scaled by the ratio of the alphas (the lobe narrows with alpha): the smoothest
    rows' fits along n.v alone can run off to a degenerate matrix (entries of 1e7 and
    more), which this start does not."""
    size = table.shape[0]
    for i in sorted(rows, reverse=True):
        r = row_roughness(i, size)
        k = (row_roughness(i + 1, size) / r) ** 2
        for j in range(size):
            _, v = cell_view(j, size)
            guess = table[i + 1, j, :4] * np.array([k, k, k, 1.0])
            table[i, j, :4], table[i, j, 6] = fit_cell(guess, v, r * r, table[i, j, 4])
        print(f"r {r:.3f} again: worst L1 {table[i, :, 6].max():.3f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--jobs", type=int, default=4, help="processes, each a band of rows")
    parser.add_argument("--refit", type=int, nargs="*", help="only fit these rows again")
    args = parser.parse_args()
    t0 = time.perf_counter()
    path = ltc_table_path(args.size)
    if args.refit:
        table = np.load(path)
        refit_rows(table, args.refit)
        np.save(path, table)
        print(f"wrote {path} in {time.perf_counter() - t0:.0f} s")
        return
    bands = np.array_split(np.arange(args.size), args.jobs)
    with ProcessPoolExecutor(args.jobs) as pool:
        parts = pool.map(
            fit_rows, [args.size] * len(bands), [range(b[0], b[-1] + 1) for b in bands]
        )
        table = sum(parts)
    refit_rows(table, list(range(REFIT_ROWS)))
    np.save(path, table)
    print(f"wrote {path} in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
