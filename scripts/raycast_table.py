"""Issue 16's table: the renderer against the float64 ray-caster on the five-sphere scene
(app/bench/raycast.py), interior pixels, at each (subdivisions, gbuffer) setting.

    .venv/bin/python scripts/raycast_table.py [--size 640x360] [--backend egl]

Prints a Markdown table for docs/accuracy.md.
"""

from __future__ import annotations

import argparse
import time

from app.bench.raycast import five_spheres, raycast_errors
from app.frame.raycast import reference_scene
from app.gl.context import create_context

SETTINGS = [(4, "f16"), (4, "f32"), (6, "f16"), (6, "f32")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="640x360", help="WIDTHxHEIGHT")
    parser.add_argument("--backend", default="egl", choices=["egl", "osmesa"])
    args = parser.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    start = time.perf_counter()
    reference_scene(five_spheres(), (w, h))
    print(f"ray-caster: {time.perf_counter() - start:.2f} s at {w}x{h}\n")
    gl = create_context(args.backend)
    try:
        print("| settings | median | p99 | max | mean FLIP | coverage mismatch |")
        print("|---|---|---|---|---|---|")
        for subdivisions, gbuffer in SETTINGS:
            e = raycast_errors(gl, five_spheres(subdivisions, gbuffer), (w, h))
            print(
                f"| subdivisions {subdivisions}, `{gbuffer}` | {e['median']:.2e} |"
                f" {e['p99']:.2e} | {e['max']:.2e} | {e['flip_mean']:.2e} |"
                f" {e['coverage_mismatch']:.2e} |"
            )
    finally:
        gl.release()


if __name__ == "__main__":
    main()
