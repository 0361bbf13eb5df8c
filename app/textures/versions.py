"""The code each kind of prepared-texture entry is made by, declared once.

An entry of the prepared-texture cache (app/textures/cache.py) is keyed by what it is made
of and by the version of the code that makes it, so that an edit to that code retires
every entry it made. Each kind's makers are listed here, in one table: the Python modules
(paths under the package) and, for what the GL draws, the program's GLSL files (paths
under ``glsl/``), whose includes are found by reading them (``resources.glsl_closure``),
never listed by hand. A module that keys an entry asks ``version(KIND)``; the
installation's seed (app/render/prepared_seed.py) asks for its kinds' versions to see
whether it is stale, without importing the GL's modules: this module imports only the
standard library and app/resources.py.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path

from app.resources import glsl_closure

_PACKAGE = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Makers:
    """The code that makes one kind of entry: Python modules under the package, and the
    GLSL files of the program that draws it (with their includes)."""

    python: tuple[str, ...]
    glsl: tuple[str, ...] = ()


# The pass a GL-drawn entry comes from draws full-screen triangles into each level.
_LEVEL_DRAWS = ("gl/fullscreen.py", "gl/texture_storage.py")
_FULLSCREEN = "passes/fullscreen.vert"

MAKERS: dict[str, Makers] = {
    # Mip chains and filtered maps made in numpy (app/textures/maps.py ``_prepared_version``).
    "maps": Makers(
        (
            "textures/maps.py",
            "textures/mips.py",
            "textures/lean.py",
            "reference/filtering.py",
            "reference/chain.py",
            "reference/tonemap.py",
        )
    ),
    # A normal/roughness chain the GL draws (app/render/normal_chain.py).
    "gl chain": Makers(
        ("render/normal_chain.py", *_LEVEL_DRAWS), ("passes/normal_chain.frag", _FULLSCREEN)
    ),
    # A colour map's sRGB mips the GL draws (app/render/srgb_mips.py).
    "srgb mips": Makers(
        ("render/srgb_mips.py", *_LEVEL_DRAWS), ("passes/srgb_mips.frag", _FULLSCREEN)
    ),
    # An environment's prefiltered levels (app/render/ibl.py).
    "env prefilter": Makers(
        ("render/ibl.py", "gl/fullscreen.py"), ("passes/env_prefilter.frag", _FULLSCREEN)
    ),
    # The bundled environments' maps, which the installation's seed prefilters.
    "bundled environments": Makers(
        ("render/prepared_seed.py", "textures/environment.py", "reference/environment.py")
    ),
}


def version(kind: str) -> str:
    """The code version of ``kind``'s makers (``MAKERS``): a key part of its entries."""
    makers = MAKERS[kind]
    return code_version(*(_PACKAGE / name for name in makers.python), glsl=makers.glsl)


@functools.cache
def code_version(*files: str | Path, glsl: tuple[str, ...] = ()) -> str:
    """A hash of the bytes of the source ``files`` and of the GLSL files ``glsl`` with
    every file they include: 16 hex digits. Read once per process for each set."""
    digest = hashlib.sha256()
    for path in (*map(Path, files), *glsl_closure(*glsl)):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]
