"""The split sum's error against the brute-force reference (app/reference/ibl.py), as the
markdown table in docs/ibl.md: gold with the normal straight up (sky, studio) or facing a
window (the HDR image), per roughness and view angle.

    .venv/bin/python scripts/ibl_errors.py

The HDR image is written as EXR to a temporary folder and read back through the scene
loader's reader: a room of radiance 0.05 with a window of radiance 20 ahead (-Z), 20-40
degrees up.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import OpenEXR

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


def main() -> None:
    cases = [
        ("sky (T = 3, sun 37 deg up)", preetham_sky(np.array([0.5, 0.6, -0.6]), 3.0, 512),
         (0.0, 1.0, 0.0)),
        ("studio", studio(512), (0.0, 1.0, 0.0)),
        ("HDR image (window room)", room(512), (0.0, 0.5, -0.866)),
    ]  # fmt: skip
    print("| environment | roughness | " + " | ".join(f"{a:g} deg" for a in ANGLES) + " |")
    print("|---|---|" + "---|" * len(ANGLES))
    for name, env, n in cases:
        err = split_sum_errors(env, ANGLES, ROUGHNESS, n=n)
        for r, row in zip(ROUGHNESS, err, strict=True):
            cells = " | ".join(f"{100 * e:+.1f} %" for e in row)
            print(f"| {name} | {r:g} | {cells} |")


if __name__ == "__main__":
    main()
