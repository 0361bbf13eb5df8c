"""A glTF 2.0 file opened whole and checked, and the world matrix of every node.

The shared first step of the glTF reader (meshes, materials), the file's lights and its
cameras: each reads what it needs from the one ``GltfDocument``. The file is read through
app/untrusted (confined, size-checked), a GLB's header and chunks are checked byte for
byte, and the JSON is parsed with bounded nesting and checked against glTF 2.0's schema
(app/scene/gltf_schema.py) before any property is used, so that no value the file did not
write reaches the reader. Problems come back as ``GltfError(key, message)``, ``key`` a
JSON path in the file (``nodes[3].matrix``), which the caller turns into an
``InputError`` naming the scene file and its own key.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np

from app.scene.gltf_schema import SchemaError, validate
from app.untrusted import RefusedError
from app.untrusted.files import read_bytes
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy
from app.untrusted.structured import parse_json

# Where a world matrix's entries stop: the products of node scales down a hierarchy, past
# which float32 positions overflow (docs/stability.md, "Limits").
MAX_WORLD_ENTRY = 1e12

_GLB_MAGIC = b"glTF"
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942
# The keys whose values stay plain dicts (read with .get), not attribute views.
_PLAIN = frozenset({"extensions", "extras"})


class GltfError(ValueError):
    """A problem with a glTF file: ``key`` is the JSON path inside the file."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key
        self.message = message


class JsonObject:
    """A checked JSON object read by attribute (``node.mesh``); a property the file does
    not give reads as None. Nested objects are JsonObjects too, except ``extensions`` and
    ``extras``, which stay dicts."""

    def __init__(self, data: dict[str, Any]) -> None:
        for name, value in data.items():
            self.__dict__[name] = value if name in _PLAIN else _view(value)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return None

    def get(self, name: str, default: Any = None) -> Any:
        """A property by name (attribute names such as ``POSITION`` read the same way)."""
        return self.__dict__.get(name, default)

    def names(self) -> list[str]:
        return list(self.__dict__)


def _view(value: Any) -> Any:
    if isinstance(value, dict):
        return JsonObject(value)
    if isinstance(value, list):
        return [_view(v) for v in value]
    return value


class GltfDocument(JsonObject):
    """A .gltf's or .glb's checked JSON, by attribute (``doc.nodes``), with the GLB's
    binary chunk (``binary_blob``)."""

    def __init__(self, data: dict[str, Any], blob: bytes | None) -> None:
        super().__init__(data)
        self.__dict__["_blob"] = blob

    def binary_blob(self) -> bytes | None:
        return self._blob


def _glb(data: bytes) -> tuple[bytes, bytes | None]:
    """The JSON chunk and the BIN chunk (or None) of a GLB (glTF 2.0 sec. 4.4): a 12-byte
    header (magic, version 2, total length), then chunks of (length, type, data), JSON
    first; chunks of unknown types are skipped, as the specification says."""
    if len(data) < 20 or data[:4] != _GLB_MAGIC:
        raise GltfError("", "not a glTF 2.0 file (no GLB magic and header)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise GltfError("", f"not a glTF 2.0 file (a GLB of version {version}, not 2)")
    if length != len(data):
        raise GltfError(
            "", f"not a glTF 2.0 file (the GLB header's length {length} is not the file's)"
        )
    at, chunks = 12, []
    while at < length:
        if at + 8 > length:
            raise GltfError(
                "", f"not a glTF 2.0 file (a GLB chunk header at byte {at} runs past the end)"
            )
        size, kind = struct.unpack_from("<II", data, at)
        if at + 8 + size > length:
            raise GltfError(
                "", f"not a glTF 2.0 file (the GLB chunk at byte {at} runs past the end)"
            )
        chunks.append((kind, data[at + 8 : at + 8 + size]))
        at += 8 + size
    if not chunks or chunks[0][0] != _CHUNK_JSON:
        raise GltfError("", "not a glTF 2.0 file (the GLB's first chunk is not its JSON)")
    blob = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == _CHUNK_BIN else None
    return chunks[0][1], blob


def open_gltf(path: Path, policy: InputPolicy = DEFAULT_POLICY) -> GltfDocument:
    """The document of a .gltf or .glb, read and checked (``GltfError`` otherwise)."""
    limits = policy.limits
    glb = Path(path).suffix.lower() == ".glb"
    try:
        data = read_bytes(Path(path), limits.max_file_bytes if glb else limits.max_json_bytes)
    except RefusedError as exc:
        raise GltfError("", str(exc)) from None
    text, blob = _glb(data) if glb else (data, None)
    if len(text) > limits.max_json_bytes:
        raise GltfError("", f"its JSON is more than {limits.max_json_bytes >> 20} MiB")
    try:
        # NaN and Infinity parsed as numbers, so the schema names the key that holds one.
        doc = parse_json(text, limits.max_nesting, constants=True)
    except RefusedError as exc:
        raise GltfError("", f"not a glTF 2.0 file ({exc})") from None
    if not isinstance(doc, dict):
        raise GltfError("", "not a glTF 2.0 file (its JSON is not an object)")
    try:
        validate(doc, limits.max_entries)
    except SchemaError as exc:
        raise GltfError(exc.key, exc.message) from None
    return GltfDocument(doc, blob)


def _components(values: list[float] | None, count: int) -> np.ndarray | None:
    """A node property the schema checked (count finite numbers), as float64."""
    return None if values is None else np.asarray(values, np.float64).reshape(count)


def node_matrix(node: JsonObject, index: int) -> np.ndarray:
    """A node's local matrix: ``matrix`` (column-major), else T @ R @ S from
    ``translation``, ``rotation`` (a unit quaternion x, y, z, w) and ``scale``."""
    key = f"nodes[{index}]"
    matrix = _components(node.matrix, 16)
    if matrix is not None:
        return matrix.reshape(4, 4).T
    t = _components(node.translation, 3)
    q = _components(node.rotation, 4)
    s = _components(node.scale, 3)
    out = np.eye(4)
    if s is not None:
        out = np.diag([*s, 1.0])
    if q is not None:
        # Scaled by its largest component first, so that the length of a huge (finite)
        # quaternion cannot overflow to infinity.
        big = np.max(np.abs(q))
        length = big * np.linalg.norm(q / big) if big > 0.0 else 0.0
        if not 1e-6 <= length < np.inf:
            raise GltfError(f"{key}.rotation", "must be a unit quaternion")
        x, y, z, w = (q / big) / (length / big)
        r = np.eye(4)
        r[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
        out = r @ out
    if t is not None:
        out[:3, 3] += t
    return out


def world_matrices(
    doc: GltfDocument,
    max_depth: int = DEFAULT_POLICY.limits.max_node_depth,
    local: dict[int, np.ndarray] | None = None,
) -> dict[int, np.ndarray]:
    """Each node of the shown scene (``scene``, else the first, else every root node) to
    its world matrix, parents first. A node reached twice (a cycle, or a node with two
    parents) is bad input, as glTF 2.0 forbids it; so is a hierarchy deeper than
    ``max_depth`` or a world matrix with an entry past ``MAX_WORLD_ENTRY``. ``local``
    replaces the local matrices of some nodes (an animation's pose,
    app/scene/gltf_animation.py)."""
    local = local or {}
    nodes = doc.nodes or []
    if doc.scenes:
        index = doc.scene if doc.scene is not None else 0
        if not 0 <= index < len(doc.scenes):
            raise GltfError("scene", f"{index} is not one of the {len(doc.scenes)} scenes")
        roots = list(doc.scenes[index].nodes or [])
        roots_key = f"scenes[{index}].nodes"
    else:
        children = {c for n in nodes for c in (n.children or [])}
        roots = [i for i in range(len(nodes)) if i not in children]
        roots_key = "nodes"
    out: dict[int, np.ndarray] = {}
    stack = [(r, np.eye(4), roots_key, 1) for r in reversed(roots)]
    while stack:
        i, parent, key, level = stack.pop()
        if not 0 <= i < len(nodes):
            raise GltfError(key, f"node {i} does not exist ({len(nodes)} nodes)")
        if i in out:
            raise GltfError(key, f"node {i} is reached twice (a cycle or two parents)")
        if level > max_depth:
            raise GltfError(f"nodes[{i}]", f"the node hierarchy is deeper than {max_depth}")
        world = parent @ (local[i] if i in local else node_matrix(nodes[i], i))
        if not np.all(np.abs(world) <= MAX_WORLD_ENTRY):  # NaN fails too
            raise GltfError(
                f"nodes[{i}]",
                f"its world matrix has an entry past {MAX_WORLD_ENTRY:g} (the scales of "
                "its parents multiplied)",
            )
        out[i] = world
        for c in reversed(nodes[i].children or []):
            stack.append((c, world, f"nodes[{i}].children", level + 1))
    return out
