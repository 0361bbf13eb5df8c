"""A glTF file's own materials as a scene names and overrides them.

A model object's ``file_materials`` table (``FileMaterial`` in app/scene/model.py,
docs/scene-format.md) names each material of its file by a key: the material's ``name``
where it has one that no other material of the file shares and that a key path can hold
(no ``"``, ``\\`` or line break), else its index as a decimal string ("0"). ``resolved``
turns the table into overrides by material index for the glTF reader (a key the file does
not have is one ``InputError`` naming the scene file and the key); ``own_factors`` gives
the file's own values of the overridable factors, which the viewer's Material panel shows
where the scene sets none.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

from app.errors import InputError
from app.scene.model import FileMaterial


def material_keys(materials: Sequence[Any]) -> list[str]:
    """The key of each of a glTF document's ``materials`` (its JSON objects), in order."""
    names = [getattr(m, "name", None) for m in materials]
    keys = []
    for i, name in enumerate(names):
        usable = (
            isinstance(name, str)
            and name != ""
            and names.count(name) == 1
            and not any(c in name for c in '"\\\n\r')
            and not name.isdecimal()  # would read as another material's index
        )
        keys.append(name if usable else str(i))
    return keys


def key_path(index: int, key: str) -> str:
    """The scene key path of object ``index``'s file material ``key``, quoted and escaped
    as a TOML basic string (JSON's escapes are TOML's for these characters)."""
    return f"objects[{index}].file_materials.{json.dumps(key, ensure_ascii=False)}"


def resolved(
    overrides: Mapping[str, FileMaterial],
    materials: Sequence[Any],
    scene_file: str,
    index: int,
    path: object,
) -> dict[int, FileMaterial]:
    """``overrides`` by material index; a key the file lacks is an ``InputError``."""
    keys = material_keys(materials)
    out: dict[int, FileMaterial] = {}
    for key, override in overrides.items():
        if key not in keys:
            shown = ", ".join(f'"{k}"' for k in keys[:8]) or "none"
            known = shown + (f", ... {len(keys) - 8} more" if len(keys) > 8 else "")
            raise InputError(
                scene_file, key_path(index, key), f"{path} has no such material (its: {known})"
            )
        out[keys.index(key)] = override
    return out


def _numbers_or(value: object, count: int, default: list[float]) -> list[float]:
    """``value`` as ``count`` finite floats, or ``default`` where it is anything else: the
    viewer reads every material of a file, also ones no primitive uses, which the reader
    never checks."""
    items = value if isinstance(value, list | tuple) else [value]
    if len(items) < count or not all(
        isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
        for x in items[:count]
    ):
        return default
    return [float(x) for x in items[:count]]


def own_factors(material: Any) -> dict[str, Any]:
    """A glTF material's own values of ``FileMaterial``'s keys (glTF 2.0's defaults where
    the file leaves one out or writes one that is not a finite number)."""
    pbr = getattr(material, "pbrMetallicRoughness", None)
    factor = _numbers_or(getattr(pbr, "baseColorFactor", None), 4, [1.0, 1.0, 1.0, 1.0])
    extensions = getattr(material, "extensions", None)
    strength = None
    if isinstance(extensions, dict):
        own = extensions.get("KHR_materials_emissive_strength")
        if isinstance(own, dict):
            strength = own.get("emissiveStrength")
    return {
        "base_color": factor[:3],
        "alpha": factor[3],
        "metallic": _numbers_or(getattr(pbr, "metallicFactor", None), 1, [1.0])[0],
        "roughness": _numbers_or(getattr(pbr, "roughnessFactor", None), 1, [1.0])[0],
        "emissive": _numbers_or(getattr(material, "emissiveFactor", None), 3, [0.0] * 3),
        "emissive_strength": _numbers_or(strength, 1, [1.0])[0],
    }
