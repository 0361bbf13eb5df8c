"""Reading a scene file: TOML -> validated ``Scene``, or one ``InputError``.

Every failure names the file and the key path (``lights[2].range``,
``materials.gold.roughness``) the way a user would find it in the file.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from app.errors import InputError
from app.scene.model import TEXTURE_KEYS, Scene
from app.textures.environment import environment_map

_KEY_PREFIX = re.compile(r"^(?:Value error, )?([A-Za-z_][A-Za-z0-9_]*): (.*)$", re.S)


@dataclass(frozen=True)
class LoadedScene:
    """A validated scene and the file it came from (mesh paths are relative to it)."""

    scene: Scene
    path: Path

    def resolve_file(self, relative: str) -> Path:
        """A path named in the scene, relative to the scene file's folder."""
        return (self.path.parent / relative).resolve()


def key_path(loc: tuple[str | int, ...]) -> str:
    """('lights', 2, 'range') -> 'lights[2].range'."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def describe_error(error: dict) -> tuple[str, str]:
    """One pydantic error as (key path, message), the way a user finds it in the file
    (also the walkthrough's step files)."""
    loc = tuple(error["loc"])
    msg = error["msg"]
    if error["type"] == "extra_forbidden":
        return key_path(loc), "unknown key"
    match = _KEY_PREFIX.match(msg)
    if match:  # a model validator naming the key it rejects
        loc, msg = (*loc, match.group(1)), match.group(2)
    elif msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if (
        "input" in error
        and error["type"] not in ("missing",)
        and not isinstance(error["input"], dict)
    ):
        msg = f"{msg} (got {error['input']!r})"
    return key_path(loc), msg


def read_text(path: Path, kind: str = "scene file") -> str:
    """A ``kind`` file's UTF-8 text, or one ``InputError`` saying why it cannot be read."""
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(str(path), "", "no such file") from None
    except IsADirectoryError:
        raise InputError(str(path), "", f"is a folder, not a {kind}") from None
    except PermissionError:
        raise InputError(str(path), "", "permission denied") from None
    except UnicodeDecodeError as exc:
        raise InputError(str(path), "", f"not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise InputError(str(path), "", f"cannot read ({exc.strerror})") from None


def parse_scene(data: dict, path: Path) -> LoadedScene:
    """Validate already-parsed TOML data; check references between tables and files."""
    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        key, msg = describe_error(exc.errors()[0])
        raise InputError(str(path), key, msg) from None
    loaded = LoadedScene(scene, path)
    for name, material in scene.materials.items():
        key = f"materials.{name}"
        for texture_key in TEXTURE_KEYS:
            if (relative := getattr(material, texture_key)) is not None:
                _check_readable(loaded, relative, f"{key}.{texture_key}")
        if (blend := material.blend) is not None:
            if blend.material not in scene.materials or blend.material == name:
                known = ", ".join(sorted(set(scene.materials) - {name})) or "none defined"
                raise InputError(
                    str(path),
                    f"{key}.blend.material",
                    f"unknown material '{blend.material}' to paint on top (known: {known})",
                )
            if scene.materials[blend.material].blend is not None:
                raise InputError(
                    str(path),
                    f"{key}.blend.material",
                    f"'{blend.material}' has a blend itself; layers do not nest",
                )
            _check_readable(loaded, blend.mask, f"{key}.blend.mask")
            # Only layer 0 of a part samples a coat normal map (glsl/material/layers.glsl).
            for layer, where in ((name, key), (blend.material, f"materials.{blend.material}")):
                if scene.materials[layer].clearcoat_normal_map is not None:
                    raise InputError(
                        str(path),
                        f"{where}.clearcoat_normal_map",
                        "a coat normal map is not supported in a blend (blend.material "
                        f"of materials.{name})",
                    )
    for i, obj in enumerate(scene.objects):
        if obj.material is not None and obj.material not in scene.materials:
            known = ", ".join(sorted(scene.materials)) or "none defined"
            raise InputError(
                str(path),
                f"objects[{i}].material",
                f"unknown material '{obj.material}' (known: {known})",
            )
        if obj.file is not None:
            _check_readable(loaded, obj.file, f"objects[{i}].file")
    if (env := scene.environment) is not None and env.file is not None:
        # Read (and checked) now, so that a bad image is one error naming the key; the
        # path is made absolute, the way the frame (which knows no scene file) reads it.
        _check_readable(loaded, env.file, "environment.file")
        target = str(loaded.resolve_file(env.file))
        environment_map("image", target, scene_file=str(path))
        scene = scene.model_copy(update={"environment": env.model_copy(update={"file": target})})
        loaded = LoadedScene(scene, path)
    if scene.camera.from_file is not None or any(obj.import_lights for obj in scene.objects):
        # A glTF file's camera and lights become the scene's own (docs/gltf-lights-cameras.md).
        # Imported here: the module needs app.scene.geometry, which imports this one.
        from app.scene.gltf_lights_cameras import resolve

        loaded = LoadedScene(resolve(scene, path), path)
    return loaded


def _check_readable(loaded: LoadedScene, relative: str, key: str) -> None:
    """A file the scene names exists and can be opened, or an InputError naming ``key``."""
    target = loaded.resolve_file(relative)
    if not target.is_file():
        raise InputError(str(loaded.path), key, f"no such file: {target}")
    try:
        with target.open("rb") as fh:
            fh.read(1)
    except OSError as exc:
        raise InputError(str(loaded.path), key, f"cannot read {target} ({exc.strerror})") from None


def load_scene(path: str | Path) -> LoadedScene:
    """Read and validate a TOML scene file."""
    path = Path(path)
    text = read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), "", f"malformed TOML: {exc}") from None
    return parse_scene(data, path.resolve())
