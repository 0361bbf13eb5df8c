"""docs/accuracy.md's tables: the renderer against the float64 ray-caster, interior pixels.

    .venv/bin/python scripts/raycast_table.py [--size 640x360] [--backend egl]
    .venv/bin/python scripts/raycast_table.py --scenes [--width 320]

The first: the five-sphere scene (app/bench/raycast.py) at each setting of the
sphere (analytic or icosphere) and the G-buffer encoding, with directional and with point
lights. The second (``--scenes``): every bundled scene the ray-caster takes, at its own
settings with its shadows off (``unshadowed``: a shadow map's filtered edge is not a shadow
ray's, docs/shadows.md measures shadows), as tests/test_raycast.py holds them; a scene lit by
an image, sky or studio environment is listed apart (the split sum is an approximation by
design, docs/ibl.md). Both print Markdown.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from app.bench.raycast import five_spheres, raycast_errors, unshadowed
from app.frame.raycast import reference_scene
from app.gl.context import GLContext, create_context
from app.scene.loader import load_scene

# (sphere subdivisions or None for the analytic sphere, G-buffer encoding)
SETTINGS = [
    (None, "f32"),
    (None, "unorm16_base"),
    (None, "unorm16"),
    (None, "f16"),
    (4, "f16"),
    (4, "f32"),
    (6, "f16"),
    (6, "f32"),
]
SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _row(label: str, e: dict) -> str:
    return (
        f"| {label} | {e['median']:.2e} | {e['p99']:.2e} | {e['max']:.2e} |"
        f" {e['flip_mean']:.2e} | {e['coverage_mismatch']:.2e} |"
    )


def settings_table(gl: GLContext, size: tuple[int, int]) -> None:
    for point_lights in (False, True):
        lights = "two directional and two point lights" if point_lights else "two directional"
        print(f"\n{lights}:\n")
        print("| settings | median | p99 | max | mean FLIP | coverage mismatch |")
        print("|---|---|---|---|---|---|")
        for subdivisions, gbuffer in SETTINGS:
            loaded = five_spheres(subdivisions, gbuffer, point_lights)
            e = raycast_errors(gl, loaded, size)
            sphere = "analytic" if subdivisions is None else f"subdivisions {subdivisions}"
            print(_row(f"{sphere}, `{gbuffer}`", e))


def scenes_table(gl: GLContext, width: int) -> None:
    print("| scene | size | median | p99 | max | mean FLIP | coverage mismatch |")
    print("|---|---|---|---|---|---|---|")
    refused, split_sum = [], []
    for path in sorted(SCENES.glob("*.toml")):
        loaded = unshadowed(load_scene(path))
        render = loaded.scene.render
        size = (width, max(1, round(width * render.height / render.width)))
        try:
            reference_scene(loaded, (8, 8))
        except ValueError as exc:
            refused.append(f"`{path.stem}` ({exc})")
            continue
        env = loaded.scene.environment
        if env is not None and env.source != "uniform":
            split_sum.append(f"`{path.stem}` ({env.source})")
            continue
        e = raycast_errors(gl, loaded, size)
        print(_row(f"`{path.stem}` | {size[0]}×{size[1]}", e))
    print("\nLit by an image, sky or studio environment (the split sum, docs/ibl.md): ", end="")
    print(", ".join(split_sum) + ".")
    print("\nRefused: " + "; ".join(refused) + ".")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="640x360", help="WIDTHxHEIGHT")
    parser.add_argument("--scenes", action="store_true", help="the bundled scenes' table")
    parser.add_argument("--width", type=int, default=320, help="the scenes' width")
    parser.add_argument("--backend", default="egl", choices=["egl", "osmesa"])
    args = parser.parse_args()
    gl = create_context(args.backend)
    try:
        if args.scenes:
            scenes_table(gl, args.width)
            return
        w, h = (int(x) for x in args.size.split("x"))
        start = time.perf_counter()
        reference_scene(five_spheres(), (w, h))
        print(f"ray-caster: {time.perf_counter() - start:.2f} s at {w}x{h}")
        settings_table(gl, (w, h))
    finally:
        gl.release()


if __name__ == "__main__":
    main()
