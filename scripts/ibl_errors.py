"""The split sum's error against the brute-force reference (app/reference/ibl.py), as the
markdown tables in docs/ibl.md: gold with the normal straight up (sky, studio) or facing a
window (the HDR image), per roughness and view angle; each cell is the plain split sum
(the map read along R) -> the one the renderer uses (read along the dominant direction,
Lagarde & de Rousiers 2014), and the last column the mean |error| of the row.

    .venv/bin/python scripts/ibl_errors.py --ndf

instead prints the error of lighting the project's other NDFs (Beckmann, Blinn-Phong,
GTR) with GGX's prefiltered map and DFG table, on the sky and the window room, with the
mean |error| of a GGX roughness matched to the NDF's lobe width (``ggx_width_scale``);

    .venv/bin/python scripts/ibl_errors.py --anisotropy

the error of anisotropic GGX (anisotropy 0, 0.5, 0.9) lit through the isotropic split
sum -> through the bent reflection vector (app/reference/ibl.py anisotropic_bent_normal),
on the studio and the sky, the tangent along the view plane or across it;

    .venv/bin/python scripts/ibl_errors.py --flip

whole images: the renderer's split sum of four spheres (96 x 64, maps 128 wide) against
the brute-force float64 image of the same G-buffer (app/bench/ibl.py), relative RMSE and
mean FLIP per environment (needs a GL context).

    .venv/bin/python scripts/ibl_errors.py

The HDR image is written as EXR to a temporary folder and read back through the scene
loader's reader: a room of radiance 0.05 with a window of radiance 20 ahead (-Z), 20-40
degrees up.
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenEXR

from app.common.models import Model, ModelParams
from app.reference.ibl import split_sum_errors
from app.textures.environment import preetham_sky, read_environment_image, studio

ANGLES = (0.0, 30.0, 60.0, 75.0, 85.0)
ROUGHNESS = (0.25, 0.5, 0.75, 1.0)


def room(width: int) -> np.ndarray:
    with tempfile.TemporaryDirectory() as tmp:
        rgb = np.full((width // 2, width, 3), 0.05, np.float32)
        h = width // 2
        rgb[int(h * 50 / 180) : int(h * 70 / 180), int(width * 0.45) : int(width * 0.55)] = 20.0
        path = Path(tmp) / "room.exr"
        with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": rgb}) as f:
            f.write(str(path))
        return read_environment_image(path, "ibl_errors", "environment.file")


def ggx_width_scale(ndf: str, gamma: float) -> float:
    """The factor on perceptual roughness that gives GGX the same half width at half
    maximum of the slope distribution as ``ndf`` at the same alpha (small-alpha limit):
    P22 falls to half at slope t = alpha sqrt(sqrt 2 - 1) for GGX, alpha sqrt(ln 2) for
    Beckmann (and Blinn-Phong, whose cos^p with p = 2/alpha^2 - 2 tends to Beckmann), and
    alpha sqrt(2^(1/gamma) - 1) for GTR (Burley 2012). Derived here; alpha = r^2, so r
    scales by the square root of the alpha ratio."""
    ggx = math.sqrt(2.0) - 1.0
    other = math.log(2.0) if ndf in ("beckmann", "blinn_phong") else 2.0 ** (1.0 / gamma) - 1.0
    return (other / ggx) ** 0.25


def ndf_table() -> None:
    """The other NDFs lit with GGX's map: error per NDF, roughness and view."""
    envs = [
        ("sky", preetham_sky(np.array([0.5, 0.6, -0.6]), 3.0, 512), (0.0, 1.0, 0.0)),
        ("window room", room(512), (0.0, 0.5, -0.866)),
    ]
    ndfs = [("beckmann", 2.0), ("blinn_phong", 2.0), ("gtr", 1.5), ("gtr", 3.0)]
    head = " | ".join(f"{a:g} deg" for a in ANGLES)
    print(f"| environment | NDF | roughness | {head} |")
    print("|---|---|---|" + "---|" * len(ANGLES))
    means = []
    for ename, env, n in envs:
        for ndf, gamma in ndfs:
            label = ndf if ndf != "gtr" else f"gtr (gamma {gamma:g})"
            model, params = Model(ndf=ndf), ModelParams(gtr_gamma=gamma)
            plain = split_sum_errors(env, ANGLES, ROUGHNESS, n=n, model=model, params=params)
            for r, row in zip(ROUGHNESS, plain, strict=True):
                cells = " | ".join(f"{100 * e:+.1f} %" for e in row)
                print(f"| {ename} | {label} | {r:g} | {cells} |")
            k = ggx_width_scale(ndf, gamma)
            matched = split_sum_errors(
                env, ANGLES, ROUGHNESS, n=n, model=model, params=params, split_roughness=k
            )
            means.append((ename, label, k, np.abs(plain).mean(), np.abs(matched).mean()))
    print("\n| environment | NDF | r scale | mean abs, same r | mean abs, width-matched r |")
    print("|---|---|---|---|---|")
    for ename, label, k, a, b in means:
        print(f"| {ename} | {label} | {k:.3f} | {100 * a:.1f} % | {100 * b:.1f} % |")


def anisotropy_table() -> None:
    """Anisotropic gold, the isotropic split sum -> the bent reflection vector."""
    envs = [
        ("studio", studio(512)),
        ("sky", preetham_sky(np.array([0.5, 0.6, -0.6]), 3.0, 512)),
    ]
    tangents = [("along", (0.0, 0.0, 1.0)), ("across", (1.0, 0.0, 0.0))]
    angles, rough = ANGLES[:4], ROUGHNESS[:3]
    model = Model(anisotropic=True)
    head = " | ".join(f"{a:g} deg" for a in angles)
    print(f"| environment | t | anisotropy | roughness | {head} |")
    print("|---|---|---|---|" + "---|" * len(angles))
    summary = []
    for ename, env in envs:
        for tname, t in tangents:
            for an in (0.0, 0.5, 0.9):
                kw = {"model": model, "anisotropy": an, "t": t}
                iso = split_sum_errors(env, angles, rough, bent=False, **kw)
                bent = split_sum_errors(env, angles, rough, bent=True, **kw)
                for r, row0, row1 in zip(rough, iso, bent, strict=True):
                    pairs = zip(row0, row1, strict=True)
                    cells = " | ".join(f"{100 * a:+.0f} -> {100 * b:+.0f} %" for a, b in pairs)
                    print(f"| {ename} | {tname} | {an:g} | {r:g} | {cells} |")
                summary.append((ename, tname, an, np.abs(iso), np.abs(bent)))
    print("\n| environment | t | anisotropy | mean abs | median abs |")
    print("|---|---|---|---|---|")
    for ename, tname, an, a, b in summary:
        mean = f"{100 * a.mean():.1f} -> {100 * b.mean():.1f} %"
        median = f"{100 * np.median(a):.1f} -> {100 * np.median(b):.1f} %"
        print(f"| {ename} | {tname} | {an:g} | {mean} | {median} |")


def flip_rows() -> None:
    """Relative RMSE and mean FLIP of the split-sum image per environment."""
    from app.bench.ibl import flip_table
    from app.gl.context import create_context

    gl = create_context("egl")
    try:
        rows = flip_table(gl)
    finally:
        gl.release()
    print("| environment | relative RMSE | mean FLIP |")
    print("|---|---|---|")
    for row in rows:
        print(f"| {row['environment']} | {row['rel_rmse']:.3f} | {row['flip_mean']:.3f} |")


def main() -> None:
    if "--flip" in sys.argv[1:]:
        flip_rows()
        return
    if "--ndf" in sys.argv[1:]:
        ndf_table()
        return
    if "--anisotropy" in sys.argv[1:]:
        anisotropy_table()
        return
    cases = [
        ("sky (T = 3, sun 37 deg up)", preetham_sky(np.array([0.5, 0.6, -0.6]), 3.0, 512),
         (0.0, 1.0, 0.0)),
        ("studio", studio(512), (0.0, 1.0, 0.0)),
        ("HDR image (window room)", room(512), (0.0, 0.5, -0.866)),
    ]  # fmt: skip
    head = " | ".join(f"{a:g} deg" for a in ANGLES)
    print(f"| environment | roughness | {head} | mean abs |")
    print("|---|---|" + "---|" * (len(ANGLES) + 1))
    for name, env, n in cases:
        plain = split_sum_errors(env, ANGLES, ROUGHNESS, n=n, dominant=False)
        bent = split_sum_errors(env, ANGLES, ROUGHNESS, n=n, dominant=True)
        for r, row0, row1 in zip(ROUGHNESS, plain, bent, strict=True):
            pairs = zip(row0, row1, strict=True)
            cells = " | ".join(f"{100 * a:+.1f} -> {100 * b:+.1f} %" for a, b in pairs)
            means = f"{100 * np.abs(row0).mean():.1f} -> {100 * np.abs(row1).mean():.1f} %"
            print(f"| {name} | {r:g} | {cells} | {means} |")
        means = f"{100 * np.abs(plain).mean():.1f} -> {100 * np.abs(bent).mean():.1f} %"
        print(f"| {name} | all | {' | '.join('' for _ in ANGLES)} | {means} |")


if __name__ == "__main__":
    main()
