"""Where the GLSL sources and the bundled scenes live.

In a wheel they are inside the package (``app/glsl``, ``app/scenes``, put there by the
build); in a source checkout they sit at the repository root beside ``app/``.
"""

from __future__ import annotations

import re
from functools import cache
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
# A GLSL source's include line (app/gl/shaders.py splices the file it names, under glsl/).
GLSL_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.M)


def _first_existing(name: str) -> Path:
    for candidate in (_PACKAGE / name, _PACKAGE.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"cannot find the '{name}' folder next to {_PACKAGE}")


@cache
def glsl_dir() -> Path:
    """The folder holding the GLSL sources the renderer compiles."""
    return _first_existing("glsl")


def glsl_closure(*names: str) -> tuple[Path, ...]:
    """The GLSL files ``names`` (paths under ``glsl/``) and every file they include,
    transitively, each once, in the order met: what a program built from them reads, so
    that a key over their bytes (app/textures/versions.py) follows an edit
    to any include without a hand-kept list. ``FileNotFoundError`` names an include that
    is no file (a generated one, "generated/...", whose text comes from Python
    declarations that such a key would not see)."""
    root = glsl_dir()
    found: dict[str, Path] = {}
    pending = list(names)
    while pending:
        name = pending.pop(0)
        if name in found:
            continue
        path = root / name
        if not path.is_file():
            raise FileNotFoundError(f"{name}: no GLSL file under {root}")
        found[name] = path
        pending += GLSL_INCLUDE.findall(path.read_text(encoding="utf-8"))
    return tuple(found.values())


@cache
def scenes_dir() -> Path:
    """The folder holding the bundled scene files."""
    return _first_existing("scenes")


@cache
def walkthrough_dir() -> Path:
    """The folder holding the walkthrough's step files (``walkthrough/`` in a checkout,
    ``app/walkthrough_steps`` in a wheel: ``app/walkthrough`` is the code)."""
    for candidate in (_PACKAGE / "walkthrough_steps", _PACKAGE.parent / "walkthrough"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"cannot find the walkthrough's step files next to {_PACKAGE}")


@cache
def bundled_dirs() -> tuple[Path, ...]:
    """The folders of the project's own data (scenes with their meshes and textures, the
    walkthrough's steps), resolved: files there may be named by any input
    (app/untrusted/policy.py)."""
    return tuple(d.resolve() for d in (scenes_dir(), walkthrough_dir()))
