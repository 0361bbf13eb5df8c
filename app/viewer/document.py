"""The scene the viewer edits, kept as the data a scene file holds.

Every edit changes that data (a key path as the CLI prints it: ``materials.gold.roughness``,
``lights[2].range``; None removes the key) through app/scene/edits.py, in its lenient form
(the file leaves tables out, which an edit creates), and is validated by the same
``parse_scene`` as ``pbs render``: a refused value raises the same ``InputError`` with the
same one-line message, and nothing changes. Saving writes the data back as TOML with
tomlkit into the document that was loaded, so the file's comments and layout survive
wherever the edit did not replace a whole table (docs/viewer.md says which).
"""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomlkit

from app.output import atomic_write
from app.scene.edits import edited_data
from app.scene.loader import LoadedScene, parse_scene, read_text, read_toml
from app.scene.model import TEXTURE_KEYS
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy


class SceneDocument:
    """The edited scene: its data, the file it came from and the validated result."""

    def __init__(
        self, path: Path, data: dict | None = None, policy: InputPolicy = DEFAULT_POLICY
    ) -> None:
        """The scene file ``path``; or, with ``data``, a scene not saved yet that will be
        saved as ``path`` (file names in it are relative to ``path``'s folder). The files
        it names are read under ``policy`` (app/untrusted/policy.py)."""
        self.path = Path(path).resolve()
        self.policy = policy
        if data is None:
            self.mtime = self._mtime()
            self.data: dict = read_toml(self.path, policy=policy)  # InputError on a bad file
            self.loaded: LoadedScene = parse_scene(copy.deepcopy(self.data), self.path, policy)
        else:
            self.loaded = parse_scene(copy.deepcopy(data), self.path, policy)
            self.data = copy.deepcopy(data)
            self.mtime = 0.0

    def _mtime(self) -> float:
        try:
            return self.path.stat().st_mtime
        except OSError:
            return 0.0

    @property
    def scene(self):
        return self.loaded.scene

    def edited(self, changes: Mapping[str, Any]) -> tuple[dict, LoadedScene]:
        """The data with {key path: value} applied (None removes a key) and the scene it
        validates to, as a scene file would be (``app.scene.edits``, lenient: the data is
        the file as written, which leaves tables out); the document is not changed.
        ``InputError`` where refused."""
        return edited_data(self.loaded, changes, "viewer", data=self.data, lenient=True)

    def edit(self, changes: Mapping[str, Any]) -> LoadedScene:
        """Apply {key path: value} to a copy of the data, validate it as a scene file
        would be, and keep it only if valid (InputError otherwise, nothing changed)."""
        self.data, self.loaded = self.edited(changes)
        return self.loaded

    def replace(self, data: dict) -> LoadedScene:
        """Validate whole new data (a reloaded file, an undo) and keep it if valid."""
        loaded = parse_scene(copy.deepcopy(data), self.path, self.policy)
        self.data, self.loaded = copy.deepcopy(data), loaded
        return loaded

    def reload(self) -> LoadedScene:
        """Read the file again (hot reload); an InputError leaves the current state (the
        file's new time is noted, so a broken file is not read again until it changes)."""
        self.mtime = self._mtime()
        data = read_toml(self.path, policy=self.policy)
        loaded = parse_scene(copy.deepcopy(data), self.path, self.policy)
        self.data, self.loaded = data, loaded
        return loaded

    def changed_on_disk(self) -> bool:
        try:
            return self.path.stat().st_mtime != self.mtime
        except OSError:  # not saved yet
            return False

    def save(self, path: Path) -> None:
        """Write the edited scene to ``path`` as TOML, merged into the loaded file's
        document so that its comments stay; file paths in the scene are rebased so that
        they still point at the same files from the new folder."""
        path = Path(path).resolve()
        data = _without_none(rebase_paths(self.data, self.path.parent, path.parent))
        try:
            document = tomlkit.parse(read_text(self.path, policy=self.policy))
        except Exception:
            document = tomlkit.document()
        merge(document, data)

        def write(tmp: Path) -> None:
            tmp.write_text(tomlkit.dumps(document), encoding="utf-8")

        atomic_write(path, write)


def _without_none(data: Any) -> Any:
    """``data`` without its None values: TOML has no null, and None is an unset key (a
    model file's scene, ``model_document``, may carry one such as ``light_scale``)."""
    if isinstance(data, dict):
        return {k: _without_none(v) for k, v in data.items() if v is not None}
    if isinstance(data, list):
        return [_without_none(v) for v in data]
    return data


def merge(target: Any, data: dict) -> None:
    """Make the tomlkit container ``target`` hold ``data``, changing only what differs:
    unchanged tables keep their comments; arrays of tables of the same length are merged
    entry by entry."""
    for key in [k for k in target if k not in data]:
        del target[key]
    for key, value in data.items():
        old = target.get(key)
        if isinstance(value, dict) and isinstance(old, dict):
            merge(old, value)
        elif (
            isinstance(value, list)
            and value
            and all(isinstance(v, dict) for v in value)
            and isinstance(old, list)
            and len(old) == len(value)
            and all(isinstance(v, dict) for v in old)
        ):
            for entry, new in zip(old, value, strict=True):
                merge(entry, new)
        elif old != value:
            target[key] = value


def rebase_paths(data: dict, old_dir: Path, new_dir: Path) -> dict:
    """A copy of ``data`` whose relative file paths (meshes, texture maps, blend masks) are
    relative to ``new_dir`` instead of ``old_dir``."""
    out = copy.deepcopy(data)
    if old_dir == new_dir:
        return out

    def move(relative: str) -> str:
        if os.path.isabs(relative):
            return relative
        return os.path.relpath(old_dir / relative, new_dir).replace(os.sep, "/")

    for obj in out.get("objects", []):
        if isinstance(obj.get("file"), str):
            obj["file"] = move(obj["file"])
    for material in out.get("materials", {}).values():
        for key in TEXTURE_KEYS:
            if isinstance(material.get(key), str):
                material[key] = move(material[key])
        blend = material.get("blend")
        if isinstance(blend, dict) and isinstance(blend.get("mask"), str):
            blend["mask"] = move(blend["mask"])
    return out


def mesh_scene(mesh: Path) -> dict:
    """The data of a scene around one mesh file (a file dropped on the viewer): the mesh
    with its own materials, a key and a fill light, a camera the viewer then frames."""
    return {
        "background": [0.18, 0.19, 0.21],
        "camera": {"position": [0.0, 1.0, 4.0], "target": [0.0, 0.0, 0.0]},
        "lights": [
            {"type": "directional", "direction": [-0.4, -1.0, -0.6], "intensity": 3.0},
            {"type": "directional", "direction": [0.7, -0.3, 0.5], "intensity": 0.8,
             "color": [0.8, 0.9, 1.0]},
        ],
        "objects": [{"shape": "mesh", "file": mesh.name}],
    }  # fmt: skip
