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
    """The scene key path of object ``index``'s file material ``key`` (quoted)."""
    return f'objects[{index}].file_materials."{key}"'


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
            known = ", ".join(f'"{k}"' for k in keys) or "none"
            raise InputError(
                scene_file, key_path(index, key), f"{path} has no such material (its: {known})"
            )
        out[keys.index(key)] = override
    return out


def own_factors(material: Any) -> dict[str, Any]:
    """A glTF material's own values of ``FileMaterial``'s keys (glTF 2.0's defaults where
    the file leaves one out)."""
    pbr = getattr(material, "pbrMetallicRoughness", None)
    factor = list(getattr(pbr, "baseColorFactor", None) or [1.0, 1.0, 1.0, 1.0])
    metallic = getattr(pbr, "metallicFactor", None)
    roughness = getattr(pbr, "roughnessFactor", None)
    extensions = getattr(material, "extensions", None) or {}
    strength = (extensions.get("KHR_materials_emissive_strength") or {}).get(
        "emissiveStrength", 1.0
    )
    return {
        "base_color": [float(c) for c in factor[:3]],
        "alpha": float(factor[3]),
        "metallic": 1.0 if metallic is None else float(metallic),
        "roughness": 1.0 if roughness is None else float(roughness),
        "emissive": [float(c) for c in (getattr(material, "emissiveFactor", None) or [0.0] * 3)],
        "emissive_strength": float(strength),
    }
