"""A glTF file's own materials as a scene names and overrides them.

A model object's ``file_materials`` table (``FileMaterial`` in app/scene/model.py,
docs/scene-format.md) names each material of its file by a key: the material's ``name``
where it has one that no other material of the file shares and that a key path can hold
(no ``"``, ``\\`` or line break), else its index as a decimal string ("0"). ``resolved``
turns the table into overrides by material index for the glTF reader (a key the file does
not have is one ``InputError`` naming the scene file and the key); ``own_factors`` gives
the file's own values of the overridable factors, which the viewer's Material panel shows
where the scene sets none. ``restyled_layers`` gives the layers an edit of the table makes,
from the parts' own ones, where the factors alone change (what a slider in the viewer
does): the same maps, new constants, no file read but its JSON.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from app.common.material_checks import material_problems
from app.errors import InputError
from app.scene.model import FileMaterial
from app.untrusted import RefusedError

if TYPE_CHECKING:
    from app.scene.loader import LoadedScene
    from app.textures.maps import SurfaceLayer


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


# The material extensions under which a layer's constants are the factors themselves:
# any other may read the base colour, metallic or roughness factor into other constants
# (KHR_materials_specular mixes by metallic, anisotropy widens roughness: gltf_extensions).
_PLAIN_EXTENSIONS = frozenset({"KHR_materials_emissive_strength"})


def _materials(path: Path, policy: Any) -> list[Any]:
    """The ``materials`` of the glTF file ``path`` (its JSON), kept per file, size and
    modification time: a slider's every step reads them, and a .glb is read whole."""
    from app.scene.gltf_document import open_gltf

    stat = path.stat()
    stamp = (str(path), stat.st_size, stat.st_mtime_ns, policy)
    if stamp not in _READ:
        if len(_READ) >= 4:
            _READ.pop(next(iter(_READ)))
        _READ[stamp] = list(open_gltf(path, policy).materials or [])
    return _READ[stamp]


_READ: dict[tuple, list[Any]] = {}  # _materials' last few files


def _extension_names(material: Any) -> set[str]:
    extensions = getattr(material, "extensions", None)
    if extensions is None:
        return set()
    if isinstance(extensions, Mapping):
        return set(extensions)
    return set(vars(extensions))


def _factors(own: dict[str, Any], override: FileMaterial | None) -> tuple[np.ndarray, ...]:
    """(baseColorFactor RGBA, metallic, roughness, emissiveFactor, strength) as the glTF
    reader computes them (app/scene/gltf.py ``_layer``): the file's, the override's in
    their place."""
    factor = np.array([*own["base_color"], own["alpha"]], np.float64)
    metallic, roughness = float(own["metallic"]), float(own["roughness"])
    emissive, strength = np.array(own["emissive"], np.float64), float(own["emissive_strength"])
    if override is not None:
        factor, metallic, roughness = override.pbr(factor, metallic, roughness)
        emissive, strength = override.emission(emissive, strength)
    return factor, np.float64(metallic), np.float64(roughness), emissive, np.float64(strength)


def restyled_layers(
    loaded: LoadedScene,
    index: int,
    old: Mapping[str, FileMaterial],
    layers: Mapping[str, SurfaceLayer],
) -> dict[str, SurfaceLayer] | None:
    """The layers of object ``index``'s file materials whose overrides differ between
    ``old`` (the table its parts were built with) and ``loaded``'s, by key, made from the
    parts' own ``layers`` (by key): the same maps with the new base colour, alpha,
    metallic, roughness, emission and strength, as the glTF reader would make them; a
    new roughness under a normal/roughness chain a new chain, made from the images the
    old one keeps (the factor is baked into its filtered levels, which do not commute
    with it: docs/viewer.md).

    None where only building the parts again gives the reader's layer: a new chain on a
    blended part, an emissive factor turning black or not where the file has an emissive
    texture (the reader drops a texture under a black
    factor), a material extension other than the emission strength, a key the file lacks,
    a material the checks refuse, or a file that cannot be read."""
    obj = loaded.scene.objects[index]
    new = obj.file_materials or {}
    try:
        path = loaded.resolve_file(obj.file or "", f"objects[{index}].file")
        materials = _materials(path, loaded.policy)
    except (InputError, RefusedError, OSError, ValueError):  # GltfError is a ValueError
        return None
    keys = material_keys(materials)
    out: dict[str, SurfaceLayer] = {}
    for key in set(old) | set(new):
        if old.get(key) == new.get(key):
            continue
        if key not in keys:
            return None
        layer = layers.get(key)
        if layer is None:  # no part draws it
            continue
        material = materials[keys.index(key)]
        if _extension_names(material) - _PLAIN_EXTENSIONS:
            return None
        own = own_factors(material)
        before = _factors(own, old.get(key))
        factor, metallic, roughness, emissive, strength = _factors(own, new.get(key))
        maps = layer.maps
        chain = maps.get("normal_roughness")
        if chain is not None and roughness != before[2]:
            # The factor is baked into the chain's filtered levels, which do not commute
            # with it (docs/viewer.md): a new chain from the images the old one keeps.
            if chain.with_factor is None or layer.alpha_mode == "blend":
                return None  # (a blended part's pass keeps its maps: new parts)
            remade = chain.with_factor(float(roughness))
            for attr in ("wrap", "min_filter", "mag_filter", "source_key"):
                setattr(remade, attr, getattr(chain, attr))
            maps = {**maps, "normal_roughness": remade}
        if getattr(material, "emissiveTexture", None) is not None and (
            bool(emissive.any()) != bool(before[3].any())
        ):
            return None
        params = dataclasses.replace(
            layer.params,
            base_color=(float(factor[0]), float(factor[1]), float(factor[2])),
            metallic=float(metallic),
            roughness=float(roughness),
        )
        if material_problems(params, maps, emissive, float(strength)):
            return None  # the reader's own error, from building the parts again
        glow = emissive * strength
        out[key] = dataclasses.replace(
            layer,
            params=params,
            maps=maps,
            emissive=(float(glow[0]), float(glow[1]), float(glow[2])),
            alpha=float(factor[3]),
        )
    return out
