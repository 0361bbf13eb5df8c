"""Edits of a scene: key paths as a scene file writes them, set in the scene's data, and the
result validated as a scene file is.

Every front-end that changes a scene goes through here: ``pbs render --compare`` and the
viewer's split screen (app/render/compare.py), ``pbs batch``'s sweeps (app/batch), the
walkthrough's comparisons and sweeps (app/walkthrough), the viewer's panels
(app/viewer/document.py), the Python API's ``set_*`` (app/api.py) and the renderer's own
swaps of whole tables (``replace_parts``, which ``Renderer`` calls).

- A **key path** names one value: names separated by ``.``, each followed by any number of
  ``[N]`` list indices (``materials.gold.roughness``, ``lights[2].intensity``,
  ``render.tonemap``); a name is bare (letters, digits, ``_``, ``-``, as a scene file's
  bare keys) or in double quotes (a material named ``"a.b"``). ``parse_key`` reads it
  once into a tuple (``('lights', 2, 'intensity')``); a malformed one is one
  ``InputError`` naming where it came from and the key (exit code 2 in the CLI).
- An **edit** sets a path to a value (a copy of it); the value None removes the key, so
  that the scene's default applies. ``apply_edits`` sets a list of them in a scene's data
  (a dict with a scene file's keys); ``edited`` does so on a copy of a loaded scene's data
  and validates the result with ``parse_scene``: a key that does not fit is a
  ``KeyPathError``, a refused value the same one-line ``InputError`` a scene file gets,
  and nothing changes.
- **Strict** (the default, what batch, walkthrough and comparisons need): the data is a
  whole validated scene's ``model_dump``, so every table and list on the way to the key
  must exist (a typo in a material's name must not quietly add a material that nothing
  uses); only the last name may be a key the scene leaves at its default, and the schema
  refuses it if it is no key at all.
- **Lenient** (the viewer, whose data is the scene file as written, without the tables it
  leaves at their defaults): a missing table on the way is created, and a name may hold
  any character but ``.``, ``[``, ``]`` and ``"`` unquoted (the panels write
  ``materials.{name}`` for whatever the file names its materials). Everything else (lists,
  indices, the schema) is the same.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Iterable, Mapping
from typing import Any

from app.errors import InputError
from app.scene.loader import LoadedScene, key_path, parse_scene
from app.scene.model import Camera, RenderSettings, Scene

__all__ = [
    "KeyPath",
    "KeyPathError",
    "apply_edits",
    "edited",
    "edited_data",
    "get_key",
    "parse_key",
    "replace_parts",
    "set_key",
    "toml_value",
]

KeyPath = tuple[str | int, ...]
# An edit's key: the text of a key path, or one already parsed.
Key = str | KeyPath


class KeyPathError(InputError):
    """An edit's key path that does not fit: malformed, or a step of it missing from the
    data. The key is wrong, not the value (a caller may name its own field for it).
    ``edit``: the index of the edit in the list ``apply_edits`` was given, where it was."""

    edit: int | None = None


_BARE = re.compile(r"[A-Za-z0-9_-]+")
_LOOSE = re.compile(r'[^.\[\]"]+')  # lenient: what the viewer's panels write unquoted
_QUOTED = re.compile(r'"[^"\\\n]*"')
_INDEX = re.compile(r"\[(\d+)\]")
KEY_SYNTAX = (
    "not a key path: names separated by '.' with [N] list indices, as a scene file "
    "writes them (materials.gold.fresnel, lights[0].intensity, render.normal_filter)"
)


def parse_key(key: str, origin: str = "comparison", *, lenient: bool = False) -> KeyPath:
    """``'lights[0].intensity'`` -> ``('lights', 0, 'intensity')``; a malformed path is an
    ``InputError`` from ``origin`` naming it. ``lenient``: a bare name may hold any
    character but ``.[]"`` (module docstring)."""
    bare = _LOOSE if lenient else _BARE
    path: list[str | int] = []
    pos = 0
    while True:
        name = _QUOTED.match(key, pos) or bare.match(key, pos)
        if name is None:
            raise KeyPathError(origin, key, KEY_SYNTAX)
        path.append(name.group().strip('"') if name.re is _QUOTED else name.group())
        pos = name.end()
        while (index := _INDEX.match(key, pos)) is not None:
            path.append(int(index.group(1)))
            pos = index.end()
        if pos == len(key):
            return tuple(path)
        if key[pos] != ".":
            raise KeyPathError(origin, key, KEY_SYNTAX)
        pos += 1


# The tables that ``replace_parts`` swaps in without validating the scene again: each is
# validated on its own, and nothing else in a scene refers to them.
_STANDALONE = {"camera": Camera, "render": RenderSettings}


def toml_value(value: object) -> str:
    """A value as the TOML the user would write (for messages)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    return repr(value)


def _path(key: Key, origin: str, lenient: bool) -> KeyPath:
    return parse_key(key, origin, lenient=lenient) if isinstance(key, str) else tuple(key)


def get_key(data: Mapping[str, Any], key: Key, default: Any = None) -> Any:
    """The value at ``key`` (read leniently) in the scene data ``data``, or ``default``
    where the data has none (a key the file leaves at its default, a malformed path)."""
    try:
        path = _path(key, "key", lenient=True)
    except InputError:
        return default
    node: Any = data
    for part in path:
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            return default
    return node


def set_key(
    data: dict,
    path: KeyPath,
    value: object,
    file: str,
    origin: str,
    *,
    lenient: bool = False,
) -> None:
    """Set ``path`` (from ``parse_key``) in the scene data ``data`` (edited in place) to a
    copy of ``value``; None removes the key. Strict: every table and list on the way must
    exist, the last name may be a key the scene leaves at its default; lenient: a missing
    table on the way is created. A step that is not there is a ``KeyPathError`` from
    ``file`` naming the path up to it, ``origin`` in parentheses."""
    node: Any = data
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        if lenient and not last and isinstance(node, dict) and isinstance(part, str):
            node.setdefault(part, [] if isinstance(path[depth + 1], int) else {})
        problem = _missing(node, part, last)
        if problem is None and last and value is None and isinstance(part, int):
            problem = "a list entry is not removed by an edit: set the whole list"
        if problem is not None:
            raise KeyPathError(file, key_path(path[: depth + 1]), f"{problem} ({origin})")
        if not last:
            node = node[part]
        elif value is None:
            node.pop(part, None)
        else:
            node[part] = copy.deepcopy(value)


def _missing(node: object, part: str | int, last: bool) -> str | None:
    """Why the scene data ``node`` has no ``part`` to step into (or, where ``last``, to
    set), or None."""
    if isinstance(part, int):
        if not isinstance(node, list):
            return "not a list: it takes no [N] index"
        if part >= len(node):
            return f"no such entry: the list has {len(node)}" + (
                f" (indices 0..{len(node) - 1})" if node else ""
            )
        return None
    if not isinstance(node, dict):
        return "its parent is " + (
            "a list: index it with [N]" if isinstance(node, list) else "a value"
        )
    if part not in node and not last:
        return f"not in the scene (there: {', '.join(sorted(node)) or 'nothing'})"
    return None


def _pairs(edits: Mapping[Key, object] | Iterable[tuple[Key, object]]) -> list[tuple[Key, object]]:
    return list(edits.items() if isinstance(edits, Mapping) else edits)


def apply_edits(
    data: dict,
    edits: Mapping[Key, object] | Iterable[tuple[Key, object]],
    file: str,
    origin: str,
    *,
    lenient: bool = False,
) -> dict:
    """Set every (key, value) of ``edits`` in ``data``, in order (edited in place and
    returned). A key given as text is parsed with ``parse_key`` (a malformed one is an
    error from ``origin``); a missing step is ``set_key``'s error from ``file``. Either is
    a ``KeyPathError`` whose ``edit`` is the index of the edit."""
    for i, (key, value) in enumerate(_pairs(edits)):
        try:
            set_key(data, _path(key, origin, lenient), value, file, origin, lenient=lenient)
        except KeyPathError as exc:
            exc.edit = i
            raise
    return data


def edited(
    base: LoadedScene,
    edits: Mapping[Key, object] | Iterable[tuple[Key, object]],
    origin: str,
    *,
    data: dict | None = None,
    lenient: bool = False,
) -> LoadedScene:
    """``base`` with ``edits`` applied to a copy of its data, validated as a scene file is
    (``parse_scene``, under ``base``'s file and policy): a key that does not fit is a
    ``KeyPathError``, a refused value that ``InputError``. ``data``: the data ``base`` was
    validated from (the viewer's file as written); by default the scene's own
    ``model_dump``. ``edited_data`` returns the edited data too."""
    return edited_data(base, edits, origin, data=data, lenient=lenient)[1]


def edited_data(
    base: LoadedScene,
    edits: Mapping[Key, object] | Iterable[tuple[Key, object]],
    origin: str,
    *,
    data: dict | None = None,
    lenient: bool = False,
) -> tuple[dict, LoadedScene]:
    """``edited``, with the edited data (a copy; ``data`` and ``base`` are not changed).

    Edits of the camera or render table alone (every orbit step, a comparison of
    ``render.tonemap``) validate just those tables, which nothing else in a scene refers
    to, and keep the rest of ``base``; anything they refuse (and a glTF file's camera,
    ``from_file``) goes through ``parse_scene`` for the full message."""
    pairs = _pairs(edits)
    data = copy.deepcopy(data) if data is not None else base.scene.model_dump(exclude_none=True)
    apply_edits(data, pairs, str(base.path), origin, lenient=lenient)
    tables = {_path(key, origin, lenient)[0] for key, _ in pairs}
    if tables and tables <= set(_STANDALONE):
        try:
            parts = {t: _STANDALONE[t].model_validate(data.get(t, {})) for t in tables}
        except ValueError:  # pydantic's ValidationError: parse_scene words it
            parts = {}
        camera = parts.get("camera")
        if parts and not (isinstance(camera, Camera) and camera.from_file is not None):
            return data, base.with_scene(replace_parts(base.scene, **parts))
    return data, parse_scene(data, base.path, base.policy)  # which leaves data as it was


def replace_parts(scene: Scene, **changes: object) -> Scene:
    """``scene`` with whole tables replaced (``replace_parts(s, camera=c)``,
    ``materials={...}``, ``lights=[...]``): what ``Renderer`` does to its scene on each
    ``set_*``. A ``Camera`` or ``RenderSettings`` (and a ``background``) is already
    validated on its own and is swapped in as it is (every orbit step); any other change
    goes through ``Scene.model_validate`` with the rest of the scene, which makes tables
    (dicts, lists of dicts) into models and takes models as they are. The references
    between tables and files are ``parse_scene``'s (``edited``): a renderer is handed
    parts of a scene that was."""
    if all(k in _STANDALONE or k == "background" for k in changes) and all(
        isinstance(v, _STANDALONE[k]) for k, v in changes.items() if k != "background"
    ):
        return scene.model_copy(update=changes)
    return Scene.model_validate({**scene.model_dump(), **changes})
