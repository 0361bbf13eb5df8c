"""Seed an installation's prepared-texture cache: ``python -m app.render.prepared_seed [DIR]``.

The bundled environments (the studio room, the default sky) depend on nothing a scene
brings, yet a render with an empty cache prefilters them on the GL first (app/render/
ibl.py, 0.4 s of llvmpipe for the studio). This writes their prefiltered levels, keyed as
``prepared_prefilter`` keys them (the map, the settings, this GL's renderer and version,
the code's version), into a seed folder (default ``<sys.prefix>/share/pbs/prepared``,
app/textures/cache.py ``seed_directories``) that every process reads below its own cache
and never writes. ``scripts/dev.sh setup`` runs it, so an installation's first render of a
model file starts with its environment made, as a warm cache would give it. Another GL, or
edited code, makes other keys: the seed is then simply not found, and the levels are built
as before. The folder is made whole each time (its entries replaced, stale ones removed).
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

# The environments a scene gets without naming a file: the model-file look's studio room
# (app/scene/model_file.py) and the sky at its default sun and turbidity.
BUNDLED = ("studio", "sky")


def seed(directory: Path, backend: str = "egl") -> list[Path]:
    """Write the bundled environments' prefiltered levels into ``directory`` (replacing
    what it held); the entries written."""
    from app.gl.context import create_context
    from app.gl.shaders import ShaderCache
    from app.render.ibl import _SETTINGS, clear_cache, prepared_prefilter
    from app.textures import cache_keys
    from app.textures.cache import prepared_cache
    from app.textures.environment import environment_map

    saved = {k: os.environ.get(k) for k in (cache_keys.ENV_DIR, cache_keys.ENV_SEED)}
    gl = create_context(backend)
    try:
        with tempfile.TemporaryDirectory(prefix="pbs-seed-") as tmp:
            # A cache of its own, no seed read: every entry is built here, by this GL.
            os.environ[cache_keys.ENV_DIR] = tmp
            os.environ[cache_keys.ENV_SEED] = ""
            os.environ.pop(cache_keys.ENV_SWITCH, None)
            shaders = ShaderCache(gl.ctx)
            try:
                clear_cache()
                for source in BUNDLED:
                    prepared_prefilter(gl.ctx, shaders, environment_map(source), *_SETTINGS)
            finally:
                shaders.release()
            prepared_cache().flush()
            built = sorted((Path(tmp) / "textures").glob("*.npy"))
            directory.mkdir(parents=True, exist_ok=True)
            for old in directory.glob("*.npy"):
                if old.name not in {p.name for p in built}:
                    old.unlink()
            written = []
            for entry in built:
                target = directory / entry.name
                partial = directory / f".tmp-{entry.name}"
                shutil.copyfile(entry, partial)
                os.replace(partial, target)
                written.append(target)
            return written
    finally:
        gl.release()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


# The seed folder's record of the code that made it (``seed_version``).
VERSION_FILE = "VERSION"


def seed_version() -> str:
    """The code the seed's entries depend on, besides the GL: the bundled maps' makers and
    the prefilter's (app/textures/versions.py). A seed folder made by other code is remade
    by ``--if-stale``; another GL's keys are simply not found in it."""
    from app.textures.versions import version

    return f"{version('bundled environments')}-{version('env prefilter')}"


def main(argv: list[str]) -> int:
    """``[--if-stale] [DIR]``: seed DIR (default the installation's seed folder); with
    ``--if-stale`` only where it holds no seed of this code (``seed_version``)."""
    from app.textures.cache_keys import default_seed_directory

    if_stale = "--if-stale" in argv
    rest = [a for a in argv if a != "--if-stale"]
    directory = Path(rest[0]) if rest else default_seed_directory()
    version = seed_version()
    stamp = directory / VERSION_FILE
    if if_stale and stamp.is_file() and stamp.read_text().strip() == version:
        return 0
    written = seed(directory)
    stamp.write_text(version + "\n")
    total = sum(p.stat().st_size for p in written)
    print(f"{directory}: {len(written)} prepared environments, {total / 2**20:.1f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
