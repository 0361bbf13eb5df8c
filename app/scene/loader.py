"""Reading a scene file: TOML -> validated ``Scene``, or one ``InputError``.

Every failure names the file and the key path (``lights[2].range``,
``materials.gold.roughness``) the way a user would find it in the file.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from pydantic import ValidationError

from app.errors import InputError
from app.scene.model import MAX_RADIANCE, TEXTURE_KEYS, Scene
from app.untrusted import RefusedError, files
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy
from app.untrusted.structured import parse_toml

if TYPE_CHECKING:
    import numpy as np

_KEY_PREFIX = re.compile(r"^(?:Value error, )?([A-Za-z_][A-Za-z0-9_]*): (.*)$", re.S)


@dataclass(frozen=True)
class LoadedScene:
    """A validated scene, the file it came from (the paths it names are relative to its
    folder) and the policy its references are read under (app/untrusted/policy.py)."""

    scene: Scene
    path: Path
    policy: InputPolicy = field(default=DEFAULT_POLICY, compare=False)
    # Mesh parts already built from this scene's objects (app/scene/geometry.py
    # ``keep_built``): a model file's parts are built to frame the camera, and the frame
    # takes them instead of reading the file and its images again. Shared by the scenes
    # ``with_scene`` derives, keyed by what the parts depend on, taken once.
    built: dict = field(default_factory=dict, compare=False, repr=False)
    # A one-view render's camera, for the finest mip level its textures can show
    # (app/scene/sampled_levels.py): given the world points of the drawn geometry, the
    # camera table that frames them and the image size. Set by a model file's still
    # render (app/scene/model_file.py) while its parts are built; None: every level.
    still_view: Callable[[np.ndarray], tuple[dict, tuple[int, int]]] | None = field(
        default=None, compare=False, repr=False
    )

    def resolve_file(self, relative: str, key: str) -> Path:
        """A path the scene names at ``key``, relative to the scene file's folder and
        confined to the folders the policy allows (an ``InputError`` naming ``key``
        otherwise, which says nothing about the file)."""
        try:
            return files.confine(relative, self.path, self.policy)
        except RefusedError as exc:
            raise InputError(str(self.path), key, str(exc)) from None

    def with_scene(self, scene: Scene) -> LoadedScene:
        """The same file and policy with another (edited) scene."""
        return replace(self, scene=scene)


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


def read_text(path: Path, kind: str = "scene file", policy: InputPolicy = DEFAULT_POLICY) -> str:
    """A ``kind`` file's UTF-8 text, or one ``InputError`` saying why it cannot be read: a
    missing file, a folder, a FIFO or device (refused before it is opened), a file past
    ``Limits.max_text_bytes``, bytes that are not UTF-8."""
    try:
        return files.read_text(Path(path), policy.limits.max_text_bytes)
    except RefusedError as exc:
        message = str(exc).removeprefix(f"{path}: ")
        if message == "is a folder, not a file":
            message = f"is a folder, not a {kind}"
        raise InputError(str(path), "", message) from None


def read_toml(path: Path, kind: str = "scene file", policy: InputPolicy = DEFAULT_POLICY) -> dict:
    """A ``kind`` TOML file parsed, its nesting bounded (app/untrusted/structured.py)."""
    text = read_text(path, kind, policy)
    try:
        return parse_toml(text, policy.limits.max_nesting)
    except RefusedError as exc:
        raise InputError(str(path), "", str(exc)) from None


def parse_scene(data: dict, path: Path, policy: InputPolicy = DEFAULT_POLICY) -> LoadedScene:
    """Validate already-parsed TOML data; check references between tables and files,
    every file confined by ``policy``."""
    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        key, msg = describe_error(exc.errors()[0])
        raise InputError(str(path), key, msg) from None
    loaded = LoadedScene(scene, path, policy)
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
        target = _check_readable(loaded, env.file, "environment.file")
        from app.textures.environment import environment_map  # imported only when used

        texels = environment_map("image", str(target), scene_file=str(path), limits=policy.limits)
        brightest = float(texels.max(initial=0.0)) * env.intensity
        if brightest > MAX_RADIANCE:  # what the light sum keeps finite in float32
            raise InputError(
                str(path),
                "environment.file",
                f"{target}: its brightest texel times intensity is {brightest:.3g}, past the "
                f"radiance limit of {MAX_RADIANCE:g}",
            )
        env = env.model_copy(update={"file": str(target)})
        loaded = loaded.with_scene(scene.model_copy(update={"environment": env}))
    if scene.camera.from_file is not None or any(obj.import_lights for obj in scene.objects):
        # A glTF file's camera and lights become the scene's own (docs/gltf-lights-cameras.md);
        # the glTF reader is imported only here, so that most scenes validate without it.
        from app.scene.gltf_lights_cameras import resolve

        loaded = loaded.with_scene(resolve(loaded.scene, path, policy))
    return loaded


def _check_readable(loaded: LoadedScene, relative: str, key: str) -> Path:
    """The confined path of a file the scene names, which must be a plain file that
    opens, or an InputError naming ``key``."""
    target = loaded.resolve_file(relative, key)
    try:
        files.check_readable(target, loaded.policy.limits.max_file_bytes)
    except RefusedError as exc:
        raise InputError(str(loaded.path), key, str(exc)) from None
    return target


def load_scene(path: str | Path, policy: InputPolicy = DEFAULT_POLICY) -> LoadedScene:
    """Read and validate a TOML scene file; the files it names are read under ``policy``."""
    path = Path(path)
    return parse_scene(read_toml(path, policy=policy), path.resolve(), policy)
