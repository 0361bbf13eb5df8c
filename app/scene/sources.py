"""Where a scene comes from: a scene file's path, the name of a bundled scene, a dict with a
scene file's keys, or a scene already loaded; all validated the one way.

``scene_from`` is the Python API's way in (``app.api`` exports it) and the CLI's
(``pbs render``, ``pbs view``): a bare name without a suffix that names no file is a
bundled scene (``showcase`` -> scenes/showcase.toml), so ``pbs render showcase`` works from
any folder.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.resources import scenes_dir
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.untrusted.policy import InputPolicy

__all__ = ["PYTHON_SCENE", "SceneSource", "scene_from", "scene_path"]

# The name a scene built in Python goes by in error messages (it has no file).
PYTHON_SCENE = "<python scene>"

SceneSource = str | Path | Mapping[str, Any] | LoadedScene


def scene_path(name: str | Path) -> Path:
    """The scene file ``name`` names: the path itself where it exists or has a suffix,
    else the bundled scene of that name where there is one, else the path (whose loading
    then says that there is no such file)."""
    path = Path(name)
    if path.exists() or path.suffix:
        return path
    bundled = scenes_dir() / f"{path}.toml"
    return bundled if bundled.is_file() else path


def scene_from(
    source: SceneSource,
    base_dir: str | Path | None = None,
    allow_paths: tuple[str | Path, ...] | list[str | Path] = (),
    max_memory: int | None = None,
) -> LoadedScene:
    """A validated scene from ``source``: a scene file's path, the name of a bundled scene
    (``"showcase"`` -> scenes/showcase.toml), a dict with a scene file's keys, or an already
    loaded scene. A dict's relative paths (mesh files, textures) are relative to
    ``base_dir`` (the working directory by default), as a file's are to its folder; its
    errors name ``<python scene>`` in that folder. Raises ``InputError``.

    Strict by default, as ``pbs render``: every file the scene names must resolve inside
    its folder (``base_dir`` for a dict) or the bundled data, unless ``allow_paths`` adds
    folders; ``max_memory`` (bytes; default 4 GiB) bounds what its decoded input and GPU
    resources may take (docs/stability.md, "Untrusted input")."""
    if isinstance(source, LoadedScene):
        return source
    policy = InputPolicy.from_options(allow_paths, max_memory)
    if isinstance(source, Mapping):
        folder = Path.cwd() if base_dir is None else Path(base_dir)
        data = copy.deepcopy(dict(source))
        return parse_scene(data, folder.resolve() / PYTHON_SCENE, policy)
    return load_scene(scene_path(source), policy)
