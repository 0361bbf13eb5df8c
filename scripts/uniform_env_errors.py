"""The uniform environment's quadrature against a converged integral (docs/ibl.md, "The
uniform environment"): the relative error of R(v) = integral f(l, v) (n.l)+ dl by the
lighting pass's directions (the float64 twin, app/reference/environment_uniform.py, which
the GLSL matches to ~1e-6) over roughness and view angle, for several models.

    .venv/bin/python scripts/uniform_env_errors.py      (~1 min on 2 cores)

The converged value is ``converged_albedo`` (the dense deterministic rule of
app/reference/quadrature.py over the same BRDF twin).
"""

from __future__ import annotations

import numpy as np

from app.brdf import reference_inputs, resolve_material
from app.reference.environment_uniform import converged_albedo, uniform_environment_albedo
from app.reference.material import ShadingPoint

MODELS = {
    "standard (grey dielectric)": {"base_color": [0.5, 0.5, 0.5]},
    "gold, exact conductor Fresnel": {"preset": "gold", "fresnel": "conductor", "metallic": 1.0},
    "thin film (oil on black)": {"base_color": [0.0, 0.0, 0.0], "ior": 1.33, "thin_film": True,
                                 "film_thickness": 400.0, "film_ior": 1.47},
    "Beckmann metal": {"ndf": "beckmann", "metallic": 1.0, "base_color": [0.9, 0.9, 0.9]},
    "sheen (Charlie) over red": {"base_color": [0.25, 0.01, 0.03], "sheen": "charlie",
                                 "sheen_color": [1.0, 0.45, 0.5], "sheen_roughness": 0.5},
    "clear coat (r_c = 0.2) over red metal": {"base_color": [0.7, 0.04, 0.03], "metallic": 1.0,
                                              "clearcoat": 1.0, "clearcoat_roughness": 0.2},
    "compensated white metal": {"metallic": 1.0, "base_color": [1.0, 1.0, 1.0],
                                "multiscatter": True},
}  # fmt: skip
ROUGHNESS = (0.0, 0.1, 0.25, 0.5, 0.75, 1.0)
VIEWS = (0.0, 30.0, 60.0, 75.0, 85.0, 89.0)
COUNTS = (64, 128, 256)


def albedos(material: dict, v: np.ndarray, count: int | None) -> np.ndarray:
    """R(v) (k, 3) about n = +Z by ``count`` directions, or converged where None."""
    params = resolve_material(material)
    s, p = reference_inputs(params)
    if count is None:
        return converged_albedo(s, p, params.model, v)
    n = np.broadcast_to([0.0, 0.0, 1.0], v.shape)
    t = np.broadcast_to([0.0, 1.0, 0.0], v.shape)
    return uniform_environment_albedo(ShadingPoint(s, p, n, None, t, v), params.model, count)


def main() -> None:
    th = np.radians(VIEWS)
    v = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], axis=-1)
    print("| model | N | " + " | ".join(f"r = {r}" for r in ROUGHNESS) + " | worst view |")
    print("|---|---|" + "---|" * (len(ROUGHNESS) + 1))
    for name, material in MODELS.items():
        want = {r: albedos({**material, "roughness": r}, v, None) for r in ROUGHNESS}
        for count in COUNTS:
            cells, worst, at = [], 0.0, 0.0
            for r in ROUGHNESS:
                got = albedos({**material, "roughness": r}, v, count)
                rel = np.abs(got - want[r]) / np.maximum(want[r], 1e-3)
                per_view = rel.max(axis=-1)
                cells.append(f"{100.0 * per_view.max():.2f} %")
                if per_view.max() > worst:
                    worst, at = per_view.max(), VIEWS[int(np.argmax(per_view))]
            print(f"| {name} | {count} | " + " | ".join(cells) + f" | {at:g}° |", flush=True)


if __name__ == "__main__":
    main()
