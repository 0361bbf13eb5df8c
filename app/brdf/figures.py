"""The walkthrough's figures beyond ``pbs brdf``'s lobes (app/brdf/plot.py), as matplotlib
``Figure`` objects (no pyplot, no window), from the float64 twins:

* ``vndf_figure``: Heitz 2018's sampling of the visible normals (RTR4 §9.6-9.8;
  app/reference/vndf.py): for each roughness and view angle, a cloud of the reflected
  directions it draws over the hemisphere, and the per-sample variance of the three
  estimators of the directional albedo (visible normals, cosine-weighted, uniform), with
  the quadrature's albedo they all estimate;
* ``layered_furnace_figure``: the white furnace of coated materials (RTR4 §9.12): the
  directional albedo of each composition against the angle of incidence, beside the
  Monte-Carlo random walk through the coat (app/reference/layered.py).

The numbers are seeded: the same figure every build.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from app.common.models import MaterialParams
from app.reference import vndf
from app.reference.multiscatter import single_scatter_albedo

if TYPE_CHECKING:
    from matplotlib.figure import Figure


VNDF_CLOUD = 300  # directions drawn per cloud
VNDF_VARIANCE_SAMPLES = 20_000  # per variance estimate


@dataclass(frozen=True)
class VarianceRow:
    """The albedo at one roughness and view angle: its quadrature value and each method's
    per-sample mean and variance (the variance of an N-sample estimate is this / N)."""

    roughness: float
    theta: float
    albedo: float
    means: dict[str, float]
    variances: dict[str, float]


def vndf_variances(roughnesses: Sequence[float], thetas: Sequence[float]) -> list[VarianceRow]:
    """The variance table of ``vndf_figure`` (seeded)."""
    rows = []
    for r in roughnesses:
        for t in thetas:
            v = vndf.view_at(t)
            x = {
                m: vndf.albedo_samples(m, v, r, VNDF_VARIANCE_SAMPLES, seed=7)
                for m in vndf.VNDF_METHODS
            }
            means = {m: float(x[m].mean()) for m in vndf.VNDF_METHODS}
            variances = {m: float(x[m].var()) for m in vndf.VNDF_METHODS}
            albedo = single_scatter_albedo(float(v[2]), r)
            rows.append(VarianceRow(r, t, albedo, means, variances))
    return rows


def vndf_figure(roughnesses: Sequence[float], thetas: Sequence[float], dpi: int = 100) -> Figure:
    """Sample clouds (rows: roughness, columns: view angle) of the directions l reflected
    about visible normals, seen from above (the disc is the hemisphere, x = l.x, y = l.y),
    with the view's mirror direction; under them the variance table."""
    from matplotlib.figure import Figure

    rows, cols = len(roughnesses), len(thetas)
    fig = Figure(figsize=(2.1 * cols + 0.4, 2.1 * rows + 2.2), dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(rows + 1, cols, height_ratios=(*([1.0] * rows), 0.9))
    circle = np.linspace(0.0, 2.0 * np.pi, 181)
    rng = np.random.default_rng(2018)
    for i, r in enumerate(roughnesses):
        alpha = max(r, 0.045) ** 2
        for j, t in enumerate(thetas):
            ax = fig.add_subplot(grid[i, j])
            v = vndf.view_at(t)
            m = vndf.sample_vndf(v, alpha, alpha, rng.random(VNDF_CLOUD), rng.random(VNDF_CLOUD))
            l = vndf.reflect(v, m)
            up = l[:, 2] > 0.0
            ax.plot(np.cos(circle), np.sin(circle), color="0.6", lw=0.8)
            ax.scatter(l[up, 0], l[up, 1], s=2, color="tab:blue", alpha=0.5, lw=0)
            ax.scatter(l[~up, 0] / np.linalg.norm(l[~up, :2], axis=-1).clip(1e-9),
                       l[~up, 1] / np.linalg.norm(l[~up, :2], axis=-1).clip(1e-9),
                       s=4, color="tab:red", marker="x", lw=0.6)  # fmt: skip
            ax.plot([-v[0]], [0.0], marker="*", color="tab:orange", ms=8)
            ax.set_xlim(-1.1, 1.1)
            ax.set_ylim(-1.1, 1.1)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            below = 100.0 * float(np.mean(~up))
            ax.set_title(f"r = {r:g}, θv = {t:g}°\nbelow horizon {below:.0f} %", fontsize=8)
    table = vndf_variances(roughnesses, thetas)
    ax = fig.add_subplot(grid[rows, :])
    ax.axis("off")
    cells = [
        [f"{row.roughness:g}", f"{row.theta:g}°", f"{row.albedo:.3f}",
         *(f"{row.variances[m]:.3g}" for m in vndf.VNDF_METHODS)]
        for row in table
    ]  # fmt: skip
    tab = ax.table(
        cellText=cells,
        colLabels=["r", "θv", "E (quadrature)", "var VNDF", "var cosine", "var uniform"],
        loc="center",
    )
    tab.auto_set_font_size(False)
    tab.set_fontsize(7)
    tab.scale(1.0, 0.95)
    fig.suptitle(
        "Visible-normal sampling (Heitz 2018): directions l seen from above\n"
        "★ mirror of v; × below the horizon (weight 0)\n"
        "table: per-sample variance of the albedo estimate, F = 1",
        fontsize=9,
    )
    return fig


# --- the layered white furnace ---------------------------------------------------------------

FURNACE_THETAS = (0.0, 30.0, 60.0, 75.0, 85.0)
FURNACE_WALK_PATHS = 6000


def walk_albedo(params: MaterialParams, thetas: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The random walk's total albedo (coat + substrate, mean over RGB) of the coated
    ``params`` at each angle, and its standard error: its base resolved inside the coat
    (medium_ior = the coat's index), a flat coat of ``clearcoat_ior``, T0 =
    ``clearcoat_color``. Seeded."""
    import dataclasses

    from app.reference.layered import random_walk
    from app.reference.material import Surface
    from app.reference.quadrature import direction
    from app.scene.model import Material

    eta = float(params.params.clearcoat_eta)
    base = Material.model_validate(
        {"base_color": list(params.base_color), "metallic": params.metallic,
         "roughness": params.roughness, "fresnel": params.model.fresnel,
         "ior": float(params.params.eta_dielectric), "medium_ior": eta}
    ).resolve()  # fmt: skip

    s = Surface(
        np.asarray(base.base_color, np.float64), base.metallic, base.roughness, base.f0, 0.0
    )
    model = dataclasses.replace(base.model, clearcoat="none")
    out, err = [], []
    for k, t in enumerate(thetas):
        w = random_walk(
            s, base.params, model, eta, tuple(params.params.clearcoat_color), direction(t),
            paths=FURNACE_WALK_PATHS, bounces=24, seed=11 + k,
        )  # fmt: skip
        out.append(float(np.mean(w.total)))
        err.append(float(np.mean(w.stderr)))
    return np.array(out), np.array(err)


def layered_furnace_figure(
    materials: Sequence[tuple[str, MaterialParams]], dpi: int = 100
) -> Figure:
    """The directional albedo (mean over RGB) of each coated material (labelled by its
    name) against the angle of incidence, by quadrature on its twin, and the random walk
    through the coat of the first one's base (points with twice their standard error);
    the line 1 is the white furnace."""
    from matplotlib.figure import Figure

    from app.reference.layered import coated_albedo
    from app.reference.material import Surface

    thetas = np.array(FURNACE_THETAS)
    fig = Figure(figsize=(6.4, 3.6), dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    ax.axhline(1.0, color="0.6", lw=0.8, ls="--")
    for name, p in materials:
        s = Surface(np.asarray(p.base_color, np.float64), p.metallic, p.roughness, p.f0, 0.0)
        total = [
            (lambda cs: cs[0] + float(np.mean(cs[1])))(coated_albedo(s, p.params, p.model, t))
            for t in thetas
        ]
        ax.plot(thetas, total, marker="o", ms=3, label=name)
    walk, err = walk_albedo(materials[0][1], thetas)
    ax.errorbar(thetas, walk, yerr=2.0 * err, fmt="k*", ms=8, capsize=3,
                label="random walk through the coat (reference, ±2 s.e.)")  # fmt: skip
    ax.set_xlabel("θ of the light (deg)")
    ax.set_ylabel("directional albedo (mean of RGB)")
    ax.set_ylim(0.0, 1.1)
    ax.set_xlim(0.0, 90.0)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("White furnace of a coated white Lambertian base", fontsize=9)
    return fig
