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

    .venv/bin/python scripts/ibl_errors.py --spheres [--json out.json | --from-json out.json]

the distribution of the renderer's error over whole spheres: per environment (sky, studio,
window room, maps 128 wide) and roughness, a gold and a grey dielectric sphere rendered by
the GPU split sum read along the mirror direction R and along the dominant direction,
each pixel against a Monte Carlo truth of the same G-buffer (``monte_carlo_radiance``: 512
GGX visible-normal, 512 cosine and 512 map-luminance directions per pixel, the map read
bilinearly; its noise measured as the FLIP between its two independent halves):
FLIP per pixel (mean, median, 95th percentile) and the relative error of the pixel's
luminance, over the whole sphere and over its grazing rim (n.v < 0.34, views past 70
degrees) (needs a GL context; about 10 minutes on two cores).

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


SPHERE_ROUGHNESS = (0.1, 0.25, 0.5, 0.75, 1.0)
SPHERE_MATERIALS = (
    ("gold", 'preset = "gold"'),
    ("grey dielectric", "base_color = [0.5, 0.5, 0.5]\nmetallic = 0.0"),
)
RIM_COS = 0.34  # n.v below it: views past ~70 degrees, the split sum's grazing failure
SPHERE_SIZE = (360, 150)
MC_SAMPLES = 512  # per pixel and strategy, in two independent halves
DIRECTIONS = ("mirror", "dominant", "view-dependent")  # app.render.ibl.reflection_direction


def spheres_scene(folder: Path, name: str, env: np.ndarray) -> Path:
    """A row of spheres per material (SPHERE_MATERIALS), one per SPHERE_ROUGHNESS, lit by
    ``env`` as an EXR image (so the renderer prefilters the texels the reference sums),
    black background, neutral tone map; written to ``folder``."""
    import OpenEXR

    exr = folder / f"{name}.exr"
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": env.astype(np.float32)}) as f:
        f.write(str(exr))
    width, height = SPHERE_SIZE
    text = (
        f'background = [0.0, 0.0, 0.0]\n[environment]\nsource = "image"\nfile = "{exr.name}"\n'
        f'[render]\nwidth = {width}\nheight = {height}\ntonemap = "neutral"\n'
        "[camera]\nposition = [0.0, 0.0, 14.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 10.5\n"
    )
    objects = ""
    for row, (_label, body) in enumerate(SPHERE_MATERIALS):
        for col, r in enumerate(SPHERE_ROUGHNESS):
            key = f"m{row}-{col}"
            text += f"[materials.{key}]\n{body}\nroughness = {r}\n"
            x = (col - (len(SPHERE_ROUGHNESS) - 1) / 2) * 1.1
            y = 0.55 - 1.1 * row
            objects += (
                f'[[objects]]\nshape = "sphere"\nradius = 0.5\nposition = [{x:.3f}, {y:.3f}, 0.0]'
                f'\nmaterial = "{key}"\n'
            )
    path = folder / f"{name}.toml"
    path.write_text(text + objects)
    return path


def sphere_distributions(gl: object, width: int = 128) -> list[dict]:
    """Per environment, material, roughness and direction ("mirror", "dominant"): the
    FLIP and relative-error distribution of the sphere's pixels against the texel sum."""
    from app.bench.ibl import environments, render
    from app.bench.metrics import flip_map
    from app.reference.ibl import monte_carlo_radiance
    from app.reference.illumination import decode_gbuffer
    from app.reference.material import ShadingPoint
    from app.render.ibl import reflection_direction

    lum = np.array([0.2126, 0.7152, 0.0722])
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for ename, env in environments(width):
            path = spheres_scene(Path(tmp), ename, env)
            images = {}
            for direction in DIRECTIONS:
                with reflection_direction(direction):
                    images[direction], _ = render(gl, path)
            first = images["dominant"]
            dec = decode_gbuffer(first.gbuffer, first.camera)
            point = ShadingPoint(dec.surface, ModelParams(), dec.n, None, dec.t, dec.v)
            halves = monte_carlo_radiance(env, 0.0, point, MC_SAMPLES, seed=7)
            ref = np.zeros((*dec.covered.shape, 3))
            ref[dec.covered] = halves.mean(0)
            half_a, half_b = np.zeros_like(ref), np.zeros_like(ref)
            half_a[dec.covered], half_b[dec.covered] = halves[0], halves[1]
            noise = flip_map(half_a, half_b, first.exposure, first.tonemap)[0]
            nov = np.zeros(dec.covered.shape)
            nov[dec.covered] = np.einsum("ij,ij->i", dec.n, dec.v)
            # which sphere a pixel shows: the nearest column, the row by the image's half
            h, w = dec.covered.shape
            centre_x = np.round(np.arange(w)[None, :] / w * len(SPHERE_ROUGHNESS) - 0.5).clip(
                0, len(SPHERE_ROUGHNESS) - 1
            )
            sphere = np.broadcast_to(centre_x, (h, w)) + np.where(
                np.arange(h)[:, None] < h / 2, 0, len(SPHERE_ROUGHNESS)
            )
            for direction, image in images.items():
                fmap = flip_map(image.hdr, ref, image.exposure, image.tonemap)[0]
                with np.errstate(divide="ignore", invalid="ignore"):
                    rel = (image.hdr @ lum - ref @ lum) / (ref @ lum)
                for row, (mname, _) in enumerate(SPHERE_MATERIALS):
                    for col, r in enumerate(SPHERE_ROUGHNESS):
                        mask = dec.covered & (sphere == row * len(SPHERE_ROUGHNESS) + col)
                        # the sphere's own pixels, its silhouette's last ring left out
                        # (their G-buffer normal is the edge's, and FLIP's filter
                        # reaches the black background there)
                        inner = mask & (nov > 0.12)
                        rim = inner & (nov < RIM_COS)
                        f, e = fmap[inner], np.abs(rel[inner])
                        rows.append({
                            "environment": ename, "material": mname, "roughness": r,
                            "direction": direction, "pixels": int(inner.sum()),
                            "flip_mean": float(f.mean()), "flip_median": float(np.median(f)),
                            "flip_p95": float(np.percentile(f, 95)),
                            "flip_rim": float(fmap[rim].mean()),
                            "rel_median": float(np.median(e)),
                            "rel_p95": float(np.percentile(e, 95)),
                            "rel_rim": float(np.median(np.abs(rel[rim]))),
                            "truth_noise_flip": float(noise[inner].mean()),
                        })  # fmt: skip
    return rows


def spheres_table(rows: list[dict]) -> None:
    """The markdown tables of docs/ibl.md from ``sphere_distributions``' rows: each cell
    mirror -> dominant."""
    keyed = {(r["environment"], r["material"], r["roughness"], r["direction"]): r for r in rows}
    cols = [("flip_mean", "FLIP mean", 3), ("flip_p95", "FLIP p95", 3),
            ("flip_rim", "rim FLIP mean", 3), ("rel_median", "\\|rel. err.\\| median", 1),
            ("rel_p95", "\\|rel. err.\\| p95", 0)]  # fmt: skip
    names = {"image": "window room"}
    head = " | ".join(c[1] for c in cols)
    print(f"| environment | material | r | {head} |")
    print("|---|---|---|" + "---|" * len(cols))
    order = {n: i for i, n in enumerate(("sky", "studio", "image"))}
    for env in sorted({r["environment"] for r in rows}, key=lambda e: order.get(e, 9)):
        for mat, _ in SPHERE_MATERIALS:
            for rough in SPHERE_ROUGHNESS:
                found = [keyed.get((env, mat, rough, d)) for d in DIRECTIONS]
                found = [f for f in found if f is not None]
                cells = []
                for key, _, digits in cols:
                    scale, unit = (100.0, " %") if key.startswith("rel") else (1.0, "")
                    cells.append(" -> ".join(f"{scale * f[key]:.{digits}f}" for f in found) + unit)
                print(f"| {names.get(env, env)} | {mat} | {rough:g} | {' | '.join(cells)} |")
    print("\n| environment | FLIP mean | spheres' FLIP p95 | rim FLIP mean | truth's noise |")
    print("|---|---|---|---|---|")
    for env in sorted({r["environment"] for r in rows}, key=lambda e: order.get(e, 9)):
        out = []
        for key in ("flip_mean", "flip_p95", "flip_rim"):
            vals = []
            for d in DIRECTIONS:
                sel = [r for r in rows if r["environment"] == env and r["direction"] == d]
                if sel:
                    w = np.array([r["pixels"] for r in sel], float)
                    vals.append(float(np.average([r[key] for r in sel], weights=w)))
            out.append(" -> ".join(f"{x:.3f}" for x in vals))
        sel = [r for r in rows if r["environment"] == env and r["direction"] == "dominant"]
        noise = np.average([r["truth_noise_flip"] for r in sel], weights=[r["pixels"] for r in sel])
        print(f"| {names.get(env, env)} | {' | '.join(out)} | {noise:.3f} |")


def main() -> None:
    if "--spheres" in sys.argv[1:]:
        import json

        from app.gl.context import create_context

        args = sys.argv[1:]
        if "--from-json" in args:  # the tables again from a run's rows
            rows = json.loads(Path(args[args.index("--from-json") + 1]).read_text())
            spheres_table(rows)
            return
        gl = create_context("egl")
        try:
            rows = sphere_distributions(gl)
        finally:
            gl.release()
        if "--json" in args:
            Path(args[args.index("--json") + 1]).write_text(json.dumps(rows, indent=1))
        spheres_table(rows)
        return
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
