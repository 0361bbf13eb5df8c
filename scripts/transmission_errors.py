"""docs/transmission.md's error table and comparison image: the transmission pass's glass
sphere against the float64 ray-caster's exact refraction (app/bench/transmission.py), per
roughness, index and thickness. Prints the markdown table with the load it ran under;
with ``--image PATH`` also writes four cases side by side (pbs left, ray-cast right)."""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from PIL import Image

from app.bench.transmission import (
    CASES,
    SIZE,
    glass_scene,
    gpu_image,
    reference,
    transmission_table,
)
from app.gl.context import create_context
from app.reference.tonemap import post_process

SHOWN = ("thin, smooth", "thin, roughness 0.5", "solid, ior 1.5", "solid, ior 1.5, amber")


def comparison_image(gl: object, path: Path, samples: int = 16) -> None:
    """Each shown case a row: the renderer's image, then the ray-caster's, tone-mapped."""
    rows = []
    for case in (c for c in CASES if c.name in SHOWN):
        data = glass_scene(case, SIZE)
        ref, _, _ = reference(data, samples)
        rows.append(np.concatenate([gpu_image(gl, data), ref], axis=1))  # type: ignore[arg-type]
    display = np.clip(post_process(np.concatenate(rows, axis=0), 0.0, "neutral"), 0.0, 1.0)
    Image.fromarray((display * 255.0 + 0.5).astype(np.uint8)).save(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--image", type=Path, help="also write the comparison image here")
    args = parser.parse_args()
    gl = create_context("auto")
    start = time.perf_counter()
    table = transmission_table(gl)
    took = time.perf_counter() - start
    print(table)
    print(f"\n{SIZE[0]}x{SIZE[1]}, {took:.0f} s, 1-minute load {os.getloadavg()[0]:.1f}")
    if args.image is not None:
        comparison_image(gl, args.image)
    gl.release()


if __name__ == "__main__":
    main()
