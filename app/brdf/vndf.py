"""The distribution of visible normals (RTR4 §9.6: the microfacets the eye sees
change with the view angle), plotted for docs/microfacet.md.

Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
eq. 38: D_v(m) = G1(v, m) (v.m)+ D(m) / (n.v), with Smith's G1 = chi+(v.m) / (1 + Lambda(v)).
It integrates to 1 over the sphere of normals for every v (that is the masking identity
of RTR4 §9.7, int G1 D (v.m)+ dm = n.v, which tests/test_microfacet.py proves for
every NDF). The renderer never samples it (no importance sampling), so it has no GLSL:
it is built here from the float64 twins' D and Lambda.

``python -m app.brdf.vndf -o docs/images/vndf.png`` writes the figure.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.output import atomic_write
from app.reference.masking import Lambda_beckmann, Lambda_GGX
from app.reference.ndf import D_GGX, D_beckmann

N = np.array([0.0, 0.0, 1.0])
NDFS: dict[str, tuple[Callable, Callable]] = {
    "GGX": (D_GGX, Lambda_GGX),
    "Beckmann": (D_beckmann, Lambda_beckmann),
}


def D_visible(ndf: str, m: np.ndarray, theta_v: float, alpha: float) -> np.ndarray:
    """Heitz 2014 eq. 38 for normals m (..., 3), the view at theta_v from n in the xz-plane."""
    D, Lambda = NDFS[ndf]
    v = np.array([math.sin(theta_v), 0.0, math.cos(theta_v)])
    vm = m @ v
    g1 = np.where(vm > 0.0, 1.0 / (1.0 + Lambda(v[2], alpha)), 0.0)
    return g1 * np.maximum(vm, 0.0) * D(N, m, alpha) / v[2]


def in_plane(theta_m: np.ndarray) -> np.ndarray:
    """Normals in the plane of incidence at signed angles theta_m from n (+ towards v)."""
    return np.stack([np.sin(theta_m), np.zeros_like(theta_m), np.cos(theta_m)], axis=-1)


def total(ndf: str, theta_v: float, alpha: float, n: int = 2048) -> float:
    """int D_v(m) dm over the hemisphere of normals (midpoint rule in cos theta_m and
    phi_m; D_v vanishes below it): 1 up to the quadrature's error."""
    u = (np.arange(n) + 0.5) / n  # cos theta_m, uniform in solid angle with phi
    phi = (np.arange(n // 4) + 0.5) / (n // 4) * 2.0 * math.pi
    c, p = np.meshgrid(u, phi, indexing="ij")
    s = np.sqrt(1.0 - c * c)
    m = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1)
    dv = D_visible(ndf, m, theta_v, alpha)
    return float(dv.sum() * (1.0 / n) * (2.0 * math.pi / (n // 4)))


def plot(path: Path, alpha: float = 0.5, thetas_deg: tuple[float, ...] = (0, 30, 60, 80)) -> None:
    """D_v in the plane of incidence against the normal's signed angle (positive towards
    the viewer), one panel per NDF, one curve per view angle, each with its integral over
    all normals in the legend."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.6, 3.6), dpi=110, layout="constrained")
    theta_m = np.linspace(-math.pi / 2, math.pi / 2, 721)
    axes = fig.subplots(1, len(NDFS), sharey=True)
    for ax, ndf in zip(axes, NDFS, strict=True):
        for t in thetas_deg:
            tv = math.radians(t)
            dv = D_visible(ndf, in_plane(theta_m), tv, alpha)
            line = ax.plot(np.degrees(theta_m), dv, label=f"θv = {t}°  (∫ D_v dm = "
                           f"{total(ndf, tv, alpha):.4f})")[0]  # fmt: skip
            ax.axvline(t, color=line.get_color(), linestyle=":", linewidth=0.8)
        ax.set_title(f"{ndf}, α = {alpha}", fontsize=10)
        ax.set_xlabel("θm, the normal's angle from n (°), + towards the viewer")
        ax.set_xlim(-90, 90)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7.5)
    axes[0].set_ylabel("D_v(m), in the plane of incidence (1/sr)")
    fig.suptitle("Visible normals D_v(m) = G1(v, m) (v·m)+ D(m) / (n·v) (Heitz 2014): "
                 "dotted, the view direction", fontsize=10)  # fmt: skip
    atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=fig.dpi))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--out", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--alpha", type=float, default=0.5)
    args = parser.parse_args(argv)
    plot(args.out, args.alpha)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
