"""A turntable: the camera orbits a scene, N frames into numpy and PNG files.

The renderer is built once; each frame moves the camera only (new matrices: nothing is
compiled or uploaded again), so frame 2 onwards costs a frame, not a rebuild.

    python docs/examples/turntable.py --scene showcase --frames 24 --size 320x180 --out turntable
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from PIL import Image

from app.api import OffscreenRenderer


def turntable(
    scene: str = "showcase",
    frames: int = 24,
    size: tuple[int, int] = (320, 180),
    out: Path | None = None,
) -> np.ndarray:
    """``frames`` images, (frames, H, W, 3) uint8, of the camera circling the scene's
    target at its height and distance; each also saved as out/frame_NNN.png if ``out``."""
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    images = []
    with OffscreenRenderer(scene, size=size) as r:
        target = np.array(r.scene.camera.target)
        offset = np.array(r.scene.camera.position) - target
        radius, start = math.hypot(offset[0], offset[2]), math.atan2(offset[0], offset[2])
        for i in range(frames):
            angle = start + 2.0 * math.pi * i / frames
            step = np.array([radius * math.sin(angle), offset[1], radius * math.cos(angle)])
            position = target + step
            r.set_camera(position=position.tolist())
            image = r.render()
            images.append(image)
            if out is not None:
                Image.fromarray(image).save(out / f"frame_{i:03d}.png")
    return np.stack(images)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="showcase")
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--size", default="320x180", help="WIDTHxHEIGHT")
    parser.add_argument("--out", type=Path, default=Path("turntable"))
    args = parser.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    images = turntable(args.scene, args.frames, (w, h), args.out)
    print(f"{args.out}: {len(images)} frames of {w}x{h}")


if __name__ == "__main__":
    main()
