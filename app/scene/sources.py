"""Where a scene comes from: a scene file's path, the name of a bundled scene, a dict with a
scene file's keys, or a scene already loaded; all validated the one way.

``scene_from`` is the Python API's way in (``app.api`` exports it) and the CLI's
(``pbs render``, ``pbs view``): a bare name without a suffix that names no file is a
bundled scene (``showcase`` -> scenes/showcase.toml), so ``pbs render showcase`` works from
any folder. A model file (.glb, .gltf, .obj, .stl, .ply) is shown without a scene file:
a scene framed and lit by the defaults of app/scene/model_file.py, which also fill in the
camera and lights of a scene file that names meshes but gives neither.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from app.errors import InputError
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.scene.look import MODEL_SUFFIXES, Look, is_model_file, needs_defaults
from app.untrusted.policy import InputPolicy

__all__ = ["PYTHON_SCENE", "Look", "SceneSource", "scene_from", "scene_path"]

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
    look: Look | None = None,
    size: tuple[int, int] | None = None,
    still: bool = False,
) -> LoadedScene:
    """A validated scene from ``source``: a scene file's path, the name of a bundled scene
    (``"showcase"`` -> scenes/showcase.toml), a dict with a scene file's keys, or an already
    loaded scene. A dict's relative paths (mesh files, textures) are relative to
    ``base_dir`` (the working directory by default), as a file's are to its folder; its
    errors name ``<python scene>`` in that folder. Raises ``InputError``.

    Strict by default, as ``pbs render``: every file the scene names must resolve inside
    its folder (``base_dir`` for a dict) or the bundled data, unless ``allow_paths`` adds
    folders; ``max_memory`` (bytes; default 4 GiB) bounds what its decoded input and GPU
    resources may take (docs/stability.md, "Untrusted input").

    A model file's path (``"teapot.obj"``, ``"model.glb"``) gives a scene that frames and
    lights it (app/scene/model_file.py); ``look`` picks the view, camera and environment
    (a ``Look``), ``size`` the image size the camera frames for (default 1280x720);
    ``still``: rendered once from that camera, so its textures' finest levels that the
    camera cannot sample are never decoded (``model_scene``). A
    scene file that names meshes but no camera or no light gets the same defaults."""
    if isinstance(source, LoadedScene):
        return source
    look = look or Look()
    if look.env not in ("studio", "sky"):  # an environment image named by the caller
        allow_paths = (*allow_paths, Path(look.env).resolve().parent)
    policy = InputPolicy.from_options(allow_paths, max_memory)
    if isinstance(source, Mapping):
        folder = Path.cwd() if base_dir is None else Path(base_dir)
        data = copy.deepcopy(dict(source))
        return parse_scene(data, folder.resolve() / PYTHON_SCENE, policy)
    path = scene_path(source)
    if is_model_file(path):
        from app.scene.model_file import model_scene

        return model_scene(path, policy, look, size, still)
    if path.suffix.lower() not in ("", ".toml"):
        raise InputError(
            str(path),
            "",
            f"unsupported file type '{path.suffix}': expected a scene file (.toml) or a model "
            f"file ({', '.join(MODEL_SUFFIXES)})",
        )
    if look.pose():
        raise InputError(
            str(path),
            f"--{next(iter(look.pose()))}",
            "applies only to a model file; a scene file poses a glTF object with its "
            "animation, time and variant keys",
        )
    loaded = load_scene(path, policy)
    if needs_defaults(loaded) == (False, False):
        if look != Look():
            raise InputError(
                str(path),
                "",
                "gives its own camera and lights: a view, camera or environment option "
                "applies only to a model file or a scene file that gives neither",
            )
        return loaded
    # The framing defaults build geometry (the mesh readers, the texture and environment
    # decoders): imported by a scene file that needs them, once it is valid.
    from app.scene.model_file import with_defaults

    return with_defaults(loaded, look, size)
