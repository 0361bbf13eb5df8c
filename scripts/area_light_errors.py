"""docs/area_lights.md's tables: the LTC area lights against the float64 truth.

1. Per shape and perceptual roughness: the twin's LTC radiance (app/reference/area_lights.py
   ``area_light_term``, what the GLSL computes) against ``area_light_exact`` (the integral
   over the light, both sampling strategies, float64) at 64 points on a dielectric floor
   lit from 1 to 2 m (app/reference/area_light_sets.py, the tests' set too), viewed from 10 to 60
   degrees over the floor: the largest and the mean |LTC - exact| over the set's largest
   value; and the same for a point light of the light's power at its centre.
2. scenes/sec4_area_lights.toml rendered by the GPU (the LTC) against the float64
   ray-caster (app/frame/raycast.py, area lights integrated exactly): relative error of
   the interior pixels' radiance where the area light dominates.
3. ``--sides``: per curved shape and polygon sides, the error against the truth and
   against a 96-gon (the polygon's own error), over the roughness set.

    python scripts/area_light_errors.py [--samples 16384] [--scene-size 192 80]
        [--skip-table] [--skip-scene] [--sides]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.common.models import DEFAULT_MODEL
from app.reference.area_light_sets import floor_points, sample_lights
from app.reference.area_lights import area_light_exact, area_light_term

ROUGHNESS = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0)
SIDES = (6, 8, 10, 12, 16, 24, 96)  # the sides table's polygons (a tube's caps: half)


def point_equivalent(point, light) -> np.ndarray:
    """A point light of the area light's power at its centre (tests' ``as_point``, for every
    shape: c_light = L A / pi with A the projected area of ``area_radiance``)."""
    from app.reference.area_lights import area_radiance
    from app.reference.material import brdf_eval

    scale = area_radiance(light.type, np.ones(3), light.axis_u, light.axis_v, light.radius)
    c_light = light.color / scale  # the c_light the radiance was made from
    d = light.position - point.position
    d2 = np.sum(d * d, axis=-1)
    l = d / np.sqrt(d2)[:, None]
    nol = np.maximum(np.sum(l * point.n, axis=-1), 0.0)
    return brdf_eval(point, DEFAULT_MODEL, l) * c_light * (nol / d2)[:, None]


def ltc_table(samples: int) -> list[str]:
    rows = [
        "| shape | roughness | LTC max | LTC mean | point light max | point light mean |",
        "|---|---|---|---|---|---|",
    ]
    for light in sample_lights():
        for r in ROUGHNESS:
            point = floor_points(r, 64)
            want = area_light_exact(point, DEFAULT_MODEL, light, samples=samples)
            got = area_light_term(point, DEFAULT_MODEL, light)
            pt = point_equivalent(point, light)
            top = want.max()
            e = np.abs(got - want) / top
            ep = np.abs(pt - want) / top
            rows.append(
                f"| {light.type.name.lower()} | {r:g} | {e.max():.3f} | {e.mean():.4f} | "
                f"{ep.max():.3f} | {ep.mean():.4f} |"
            )
            print(rows[-1], flush=True)
    return rows


def sides_table(samples: int) -> list[str]:
    """Per curved shape (disk, sphere, tube) and polygon sides: the largest and mean
    |LTC - exact| over the set's largest value, the largest over the roughness set (64
    points each), and the largest |LTC(sides) - LTC(96)| (the polygon's own error)."""
    rows = [
        "| shape | sides | LTC max | LTC mean (worst roughness) | polygon's own max |",
        "|---|---|---|---|---|",
    ]
    for light in sample_lights()[1:]:
        exact = {}
        fine = {}
        for r in ROUGHNESS:
            point = floor_points(r, 64)
            exact[r] = area_light_exact(point, DEFAULT_MODEL, light, samples=samples)
            fine[r] = area_light_term(point, DEFAULT_MODEL, light, sides=96)
        for sides in SIDES:
            worst_max = worst_mean = own = 0.0
            for r in ROUGHNESS:
                got = area_light_term(floor_points(r, 64), DEFAULT_MODEL, light, sides=sides)
                top = exact[r].max()
                e = np.abs(got - exact[r]) / top
                worst_max = max(worst_max, e.max())
                worst_mean = max(worst_mean, e.mean())
                own = max(own, float((np.abs(got - fine[r]) / top).max()))
            rows.append(
                f"| {light.type.name.lower()} | {sides} | {worst_max:.3f} | {worst_mean:.4f} | "
                f"{own:.4f} |"
            )
            print(rows[-1], flush=True)
    return rows


def scene_errors(size: tuple[int, int], samples: int) -> list[str]:
    from app.frame.raycast import reference_scene
    from app.gl.context import create_context
    from app.render.renderer import Renderer
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    loaded = load_scene(scenes_dir() / "sec4_area_lights.toml")
    scene = loaded.scene.model_copy(
        update={"render": loaded.scene.render.model_copy(
            update={"width": size[0], "height": size[1], "antialiasing": "none",
                    "gbuffer": "f32"})}
    )  # fmt: skip
    loaded = type(loaded)(scene, loaded.path, loaded.policy)
    gl = create_context()
    r = Renderer(gl, loaded, size)
    try:
        r.render()
        gpu = r.read_hdr().astype(np.float64)
    finally:
        r.release()
    import app.reference.area_lights as al

    al.EXACT_SAMPLES = samples  # the ray-caster's samples per pixel and strategy
    ref = reference_scene(loaded, size)
    inner = ref.interior()
    right = np.zeros_like(inner)
    right[:, size[0] // 2 :] = True  # the rectangle's half
    sel = inner & right
    lum_ref = ref.hdr[sel].sum(-1)
    lum_gpu = gpu[sel].sum(-1)
    bright = lum_ref > 0.05 * lum_ref.max()
    rel = np.abs(lum_gpu - lum_ref)[bright] / lum_ref[bright]
    np.save("/tmp/area_scene_ref.npy", ref.hdr)
    np.save("/tmp/area_scene_gpu.npy", gpu)
    return [
        "| pixels | median | 90th percentile | 99th percentile | max |",
        "|---|---|---|---|---|",
        f"| {int(bright.sum())} | {np.median(rel):.4f} | {np.percentile(rel, 90):.4f} | "
        f"{np.percentile(rel, 99):.4f} | {rel.max():.4f} |",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--scene-size", type=int, nargs=2, default=(192, 80))
    parser.add_argument("--scene-samples", type=int, default=1024)
    parser.add_argument("--skip-table", action="store_true")
    parser.add_argument("--sides", action="store_true", help="only the error against sides")
    parser.add_argument("--skip-scene", action="store_true", help="no scene table")
    args = parser.parse_args()
    t0 = time.perf_counter()
    if args.sides:
        print("\n".join(sides_table(args.samples)))
        print(f"({time.perf_counter() - t0:.0f} s)")
        return
    if not args.skip_table:
        print("\n".join(ltc_table(args.samples)))
    if not args.skip_scene:
        print("\n".join(scene_errors(tuple(args.scene_size), args.scene_samples)))
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
