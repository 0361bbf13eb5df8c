"""Regenerate ``screenshots/NAME.png`` for every scene ``scenes/NAME.toml``.

``python -m app.screenshots [--backend egl|osmesa]``; the regression test renders each
scene again and compares with these images perceptually (FLIP).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from app.gl.context import GLContext, create_context
from app.output import write_png
from app.render.renderer import Renderer
from app.scene.loader import load_scene

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"
SHOTS = REPO / "screenshots"


def scene_files() -> list[Path]:
    """Every scene of the repository, sorted by name."""
    return sorted(SCENES.glob("*.toml"))


def render_scene(gl: GLContext, path: Path) -> np.ndarray:
    """The display image of one scene at its own size, (H, W, 3) uint8."""
    renderer = Renderer(gl, load_scene(path))
    try:
        renderer.render()
        return renderer.read_ldr()
    finally:
        renderer.release()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    args = parser.parse_args(argv)
    gl = create_context(args.backend)
    for path in scene_files():
        out = SHOTS / f"{path.stem}.png"
        write_png(out, render_scene(gl, path))
        print(out.relative_to(REPO))
    gl.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
