"""A roughness sweep: one sphere built in Python, its roughness changed between frames.

A material's value (no maps) changes constants only: the sphere's vertex buffer and the
programs are kept. RTR4 §9.6: as roughness rises the highlight widens and, its energy
spread wider, its peak dims, which the printed peaks show.

    python docs/examples/roughness_sweep.py --size 160x160 --out sweep.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image

from app.api import OffscreenRenderer

ROUGHNESS = (0.1, 0.2, 0.3, 0.5, 0.7, 0.9)

# A scene file's keys as a dict: validated exactly as scenes/*.toml are.
SCENE = {
    "background": [0.02, 0.02, 0.025],
    "camera": {"position": [0.0, 0.0, 4.0], "target": [0.0, 0.0, 0.0], "fov_y": 30.0},
    "materials": {"ball": {"base_color": [0.6, 0.05, 0.04], "roughness": 0.1}},
    "lights": [{"type": "directional", "direction": [-0.4, -0.5, -1.0], "intensity": 3.0}],
    "objects": [{"shape": "sphere", "radius": 1.0, "material": "ball"}],
}


def sweep(
    roughness: tuple[float, ...] = ROUGHNESS, size: tuple[int, int] = (160, 160)
) -> tuple[np.ndarray, np.ndarray]:
    """The frames side by side, (H, W * n, 3) uint8, and each frame's peak linear
    radiance (the highlight's top), (n,) float32."""
    frames, peaks = [], []
    with OffscreenRenderer(SCENE, size=size) as r:
        r.want_hdr()  # hdr() is read every frame: one lighting pass serves both images
        for value in roughness:
            r.set_material("ball", roughness=value)
            frames.append(r.render())
            peaks.append(r.hdr().max())
    return np.concatenate(frames, axis=1), np.array(peaks, np.float32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="160x160", help="WIDTHxHEIGHT of one frame")
    parser.add_argument("--out", type=Path, default=Path("sweep.png"))
    args = parser.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    strip, peaks = sweep(ROUGHNESS, (w, h))
    Image.fromarray(strip).save(args.out)
    for value, peak in zip(ROUGHNESS, peaks, strict=True):
        print(f"roughness {value:.1f}: peak radiance {peak:.3f}")


if __name__ == "__main__":
    main()
