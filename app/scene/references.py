"""Files a mesh file names, checked before trimesh reads it.

trimesh swallows a missing texture: a glTF whose base colour image is gone loads with
``baseColorTexture = None`` (it logs the error and the model renders white), and an OBJ
whose MTL is gone gets a grey default material with a white image. A glTF with an
extension the project does not decode would load as geometry it cannot draw. So the
references are read here from the files themselves, before the glTF reader
(app/scene/gltf.py) or trimesh, and each problem comes back as one sentence for an
``InputError``:

- glTF / GLB: every ``buffers[i].uri`` and ``images[i].uri`` that is not a ``data:`` URI
  must name a readable file (relative to the glTF, percent-decoded as glTF 2.0 says);
  an image must also open as one (Pillow). Every name in ``extensionsRequired`` must be
  in ``SUPPORTED_EXTENSIONS``.
- OBJ: every ``mtllib`` must name a readable file, and every map in it that the project
  reads (``MTL_MAP_KEYWORDS``: ``map_Kd``, ``map_Pr``, ``map_Pm``, ``norm``, ``map_Ke``,
  ``map_d``) a readable image, relative to the MTL's folder.

A file whose own structure is broken (not JSON, a truncated GLB header) is left to the
reader (or trimesh), which refuses it with its own message.
"""

from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote

from PIL import Image

from app.scene.gltf import meshopt_available
from app.scene.gltf_extensions import SUPPORTED as MATERIAL_EXTENSIONS

# glTF extensions a file may *require* (docs/scene-format.md, "Mesh files"): those the
# reader (app/scene/gltf.py) decodes, the material extensions it hands to
# app/scene/gltf_extensions.py, and KHR_lights_punctual (lights are optional to draw).
# EXT_meshopt_compression only where the optional meshoptimizer package imports.
SUPPORTED_EXTENSIONS: frozenset[str] = frozenset(
    {
        "KHR_draco_mesh_compression",
        "KHR_mesh_quantization",
        "KHR_texture_transform",
        "KHR_materials_emissive_strength",
        "KHR_lights_punctual",
        *MATERIAL_EXTENSIONS,
    }
    | ({"EXT_meshopt_compression"} if meshopt_available() else set())
)

# Hints for required extensions users meet most (issue 17: a Draco .glb drew nothing).
_HINTS = {
    "EXT_meshopt_compression": "meshoptimizer-compressed geometry; "
    "pip install 'pbs-lab[meshopt]' to read it",
}

_GLB_MAGIC = b"glTF"
_GLB_JSON = 0x4E4F534A  # chunk type "JSON"


def _gltf_document(path: Path) -> dict | None:
    """The JSON of a .gltf, or of a .glb's first chunk; None where it cannot be parsed."""
    try:
        with path.open("rb") as f:
            if path.suffix.lower() == ".glb":
                header = f.read(20)
                if len(header) < 20 or header[:4] != _GLB_MAGIC:
                    return None
                length, kind = struct.unpack("<II", header[12:20])
                if kind != _GLB_JSON:
                    return None
                text = f.read(length)
            else:
                text = f.read()
        doc = json.loads(text)
    except (OSError, ValueError):  # unreadable or not JSON: trimesh reports it
        return None
    return doc if isinstance(doc, dict) else None


def _unreadable(file: Path, image: bool) -> str | None:
    """Why ``file`` cannot be used (missing, a folder, unreadable, not an image), or None."""
    if not file.exists():
        return "is missing"
    if not file.is_file():
        return "is not a file"
    try:
        with file.open("rb") as f:
            f.read(1)
    except OSError as exc:  # PermissionError and the like
        return f"cannot be read ({type(exc).__name__})"
    if image:
        try:
            with Image.open(file) as img:
                img.verify()
        except Exception as exc:  # Pillow raises many types for data it cannot decode
            return f"is not an image Pillow can read ({type(exc).__name__})"
    return None


def gltf_problem(path: Path) -> str | None:
    """The first problem with a glTF/GLB's required extensions or referenced files."""
    doc = _gltf_document(path)
    if doc is None:
        return None
    required = doc.get("extensionsRequired", [])
    for name in required if isinstance(required, list) else []:
        if name not in SUPPORTED_EXTENSIONS:
            what = f" ({_HINTS[name]})" if name in _HINTS else ""
            return (
                f"{path} requires the glTF extension {name}{what}, which pbs does not "
                "read; export the file without it"
            )
    for table, image in (("buffers", False), ("images", True)):
        entries = doc.get(table, [])
        for i, entry in enumerate(entries if isinstance(entries, list) else []):
            uri = entry.get("uri") if isinstance(entry, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            file = path.parent / unquote(uri)
            why = _unreadable(file, image)
            if why is not None:
                return f"{path}: {table}[{i}].uri '{uri}': {file} {why}"
    return None


# The MTL statements naming a map the project reads (lower-case; docs/scene-format.md,
# "Mesh files"): base colour, the PBR extension's roughness, metallic and normal maps,
# emission and dissolve. ``bump`` / ``map_Bump`` are not among them: most exporters write
# a height map there, which the project does not turn into normals.
MTL_MAP_KEYWORDS = ("map_kd", "map_pr", "map_pm", "norm", "map_ke", "map_d")

# The options a map statement may put before its file name, and how many words each
# takes (Wavefront's MTL specification; -o, -s and -t take one to three numbers, -mm two).
_MTL_OPTIONS = {
    "-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
    "-imfchan": 1, "-texres": 1, "-type": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3,
}  # fmt: skip


@dataclass(frozen=True)
class MtlMap:
    """One map statement of an MTL material: the keyword as written (``map_Pr``), the
    file name as written, the file (relative to the MTL's folder) and the options."""

    keyword: str
    name: str
    file: Path
    options: dict[str, tuple[str, ...]]


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def parse_map_statement(rest: str) -> tuple[dict[str, tuple[str, ...]], str]:
    """(options, file name) of the text after a map keyword: options first, each with
    its words (up to ``_MTL_OPTIONS``'s count; -o, -s, -t stop at the first word that is
    not a number), then the file name, the rest of the line (spaces inside it kept)."""
    options: dict[str, tuple[str, ...]] = {}
    words = list(re.finditer(r"\S+", rest))
    i = 0
    while i < len(words) and words[i].group().lower() in _MTL_OPTIONS:
        option = words[i].group().lower()
        count = _MTL_OPTIONS[option]
        numeric = option in ("-mm", "-o", "-s", "-t")
        taken: list[str] = []
        i += 1
        # Leave at least one word for the file name.
        while len(taken) < count and i < len(words) - 1:
            word = words[i].group()
            if numeric and taken and not _is_number(word):
                break
            taken.append(word)
            i += 1
        options[option] = tuple(taken)
    name = rest[words[i].start() :].strip() if i < len(words) else ""
    return options, name


def mtl_materials(mtl: Path) -> dict[str, dict[str, MtlMap]]:
    """Per material (``newmtl``'s name, as trimesh keys it) its read maps by lower-case
    keyword (``MTL_MAP_KEYWORDS``); a statement before any ``newmtl`` belongs to none."""
    materials: dict[str, dict[str, MtlMap]] = {}
    current: dict[str, MtlMap] | None = None
    for line in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
        words = line.split()
        if len(words) < 2:
            continue
        keyword = words[0].lower()
        if keyword == "newmtl":
            current = materials.setdefault(" ".join(words[1:]), {})
        elif keyword in MTL_MAP_KEYWORDS and current is not None:
            rest = line.strip()[len(words[0]) :]
            options, name = parse_map_statement(rest)
            if name:
                current[keyword] = MtlMap(words[0], name, mtl.parent / name, options)
    return materials


def obj_materials(path: Path, libraries: list[str]) -> dict[str, dict[str, MtlMap]]:
    """The maps of every material of an OBJ's MTL files (``obj_libraries``), by material
    name; a name defined twice keeps its first definition. Call after ``obj_problem``
    found nothing (the files are then readable)."""
    materials: dict[str, dict[str, MtlMap]] = {}
    for name in libraries:
        for material, maps in mtl_materials(path.parent / name).items():
            materials.setdefault(material, maps)
    return materials


def obj_libraries(path: Path) -> list[str]:
    """The names of an OBJ's ``mtllib`` statements (each the rest of its line, so that a
    name with spaces stays whole); none where the file cannot be read."""
    try:
        with path.open("rb") as f:
            return [
                line[6:].strip().decode("utf-8", errors="replace")
                for line in f
                if line.startswith(b"mtllib") and line[6:7].isspace()
            ]
    except OSError:  # trimesh reports it
        return []


def obj_problem(path: Path, libraries: list[str]) -> str | None:
    """The first problem with an OBJ's ``mtllib`` files or the images of the maps they
    name that the project reads (``MTL_MAP_KEYWORDS``)."""
    for name in libraries:
        mtl = path.parent / name
        why = _unreadable(mtl, image=False)
        if why is not None:
            return f"{path}: mtllib {name}: {mtl} {why}"
        for maps in mtl_materials(mtl).values():
            for m in maps.values():
                why = _unreadable(m.file, image=True)
                if why is not None:
                    return f"{path}: {mtl.name}: {m.keyword} {m.name}: {m.file} {why}"
    return None
