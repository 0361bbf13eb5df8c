"""The walkthrough's figures beyond ``pbs brdf``'s lobes (app/brdf/plot.py), as matplotlib
``Figure`` objects (no pyplot, no window), from the float64 twins:

* ``layered_furnace_figure``: the white furnace of coated materials (RTR4 §9.12): the
  directional albedo of each composition against the angle of incidence, beside the
  Monte-Carlo random walk through the coat (app/reference/layered.py).

The numbers are seeded: the same figure every build.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from app.common.models import MaterialParams

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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
