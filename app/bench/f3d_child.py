"""f3d on a model file, one whole process: ``python -m app.bench.f3d_child MODEL OUT W H``.

The peer of the ``assets`` suite (app/bench/assets.py): f3d (the PyPI wheel ``f3d``, VTK
inside; the optional ``peers`` extra) renders MODEL offscreen at W x H with its
antialiasing on (``render.effect.antialiasing.mode = "ssaa"``), image-based lighting from
its built-in HDRI (``render.hdri.ambient``) and tone mapping, and writes OUT (PNG). The
wheel ships the library and its Python binding, not the ``f3d`` executable, so the process
is this script: Python's start (tens of ms) is counted with f3d's.

Exit status 0 on success; 3 with one line on stderr when f3d cannot be imported or cannot
render here (the bench records that line as the reason it skips the peer).
"""

from __future__ import annotations

import sys

UNAVAILABLE = 3


def main(argv: list[str]) -> int:
    model, out, width, height = argv[0], argv[1], int(argv[2]), int(argv[3])
    try:
        import f3d
    except Exception as exc:  # not installed, or its libraries cannot load
        print(f"f3d is not importable: {type(exc).__name__}: {exc}", file=sys.stderr)
        return UNAVAILABLE
    try:
        engine = f3d.Engine.create(True)  # offscreen
    except Exception as exc:
        print(f"f3d cannot open an offscreen window: {exc}", file=sys.stderr)
        return UNAVAILABLE
    options = engine.options
    options["render.effect.antialiasing.mode"] = "ssaa"
    options["render.hdri.ambient"] = True
    options["render.effect.tone_mapping"] = True
    options["ui.loader_progress"] = False
    engine.window.size = (width, height)
    engine.scene.add(model)
    engine.window.render_to_image().save(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
