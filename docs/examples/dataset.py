"""A small data set: random materials and cameras, images and depth maps saved.

One renderer for the whole set; each sample changes a material's parameters and the
camera, then saves the display image (PNG), the view depth (.npy, metres, 0 = background)
and the world-space normals (.npy), with its parameters in labels.jsonl.

    python docs/examples/dataset.py --samples 100 --size 256x256 --seed 1 --out dataset
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
from PIL import Image

from app.api import OffscreenRenderer

SCENE = {
    "background": [0.0, 0.0, 0.0],
    "camera": {"position": [0.0, 1.0, 4.0], "target": [0.0, 0.5, 0.0], "fov_y": 40.0},
    "materials": {
        "object": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.5},
        "floor": {"base_color": [0.4, 0.4, 0.4], "roughness": 0.8},
    },
    "lights": [
        {"type": "directional", "direction": [-0.5, -1.0, -0.3], "intensity": 1.2},
        {"type": "point", "position": [2.0, 2.5, 2.0], "intensity": 3.0, "range": 12.0},
    ],
    "objects": [
        {"shape": "plane", "size": [8.0, 8.0], "material": "floor"},
        {"shape": "sphere", "radius": 0.5, "position": [-0.6, 0.5, 0.0], "material": "object"},
        {"shape": "box", "size": [0.7, 0.7, 0.7], "position": [0.7, 0.35, -0.2],
         "rotation": [0.0, 30.0, 0.0], "material": "object"},
    ],
}  # fmt: skip


def dataset(
    out: Path, samples: int = 100, size: tuple[int, int] = (256, 256), seed: int = 1
) -> list[dict]:
    """Render ``samples`` random views into ``out``: sample_NNNN.png, _depth.npy,
    _normal.npy and a line of labels.jsonl each; returns the labels."""
    rng = np.random.default_rng(seed)
    out.mkdir(parents=True, exist_ok=True)
    labels = []
    with OffscreenRenderer(SCENE, size=size) as r:
        for i in range(samples):
            material = {
                "base_color": rng.uniform(0.05, 0.95, 3).round(3).tolist(),
                "roughness": round(float(rng.uniform(0.05, 1.0)), 3),
                "metallic": round(float(rng.choice([0.0, 1.0])), 1),
            }
            azimuth, elevation = rng.uniform(0.0, 2.0 * math.pi), rng.uniform(0.15, 0.9)
            distance = float(rng.uniform(3.0, 5.0))
            position = [
                distance * math.cos(elevation) * math.sin(azimuth),
                0.5 + distance * math.sin(elevation),
                distance * math.cos(elevation) * math.cos(azimuth),
            ]
            r.set_material("object", **material)
            r.set_camera(position=position)
            stem = out / f"sample_{i:04d}"
            Image.fromarray(r.render()).save(stem.with_suffix(".png"))
            g = r.channels(("depth", "normal"))
            np.save(f"{stem}_depth.npy", g["depth"])
            np.save(f"{stem}_normal.npy", g["normal"])
            labels.append({"image": stem.name + ".png", "camera": position, **material})
    with (out / "labels.jsonl").open("w") as fh:
        fh.writelines(json.dumps(label) + "\n" for label in labels)
    return labels


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100)
    parser.add_argument("--size", default="256x256", help="WIDTHxHEIGHT")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("dataset"))
    args = parser.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    labels = dataset(args.out, args.samples, (w, h), args.seed)
    print(f"{args.out}: {len(labels)} samples of {w}x{h}")


if __name__ == "__main__":
    main()
