"""The split sum's error against the brute-force reference (app/reference/ibl.py), as the
markdown tables in docs/ibl.md: gold with the normal straight up (sky, studio) or facing a
window (the HDR image), per roughness and view angle; each cell is the plain split sum
(the map read along R) -> the one the renderer uses (read along the dominant direction,
Lagarde & de Rousiers 2014), and the last column the mean |error| of the row.

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
