"""A glTF 2.0 file opened whole (pygltflib) and the world matrix of every node.

The shared first step of the glTF reader (meshes, materials), the file's lights and its
cameras: each reads what it needs from the one ``GLTF2`` document. Problems come back as
``GltfError(key, message)``, ``key`` a JSON path in the file (``nodes[3].matrix``), which
the caller turns into an ``InputError`` naming the scene file and its own key.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pygltflib


class GltfError(ValueError):
    """A problem with a glTF file: ``key`` is the JSON path inside the file."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key
        self.message = message


def open_gltf(path: Path) -> pygltflib.GLTF2:
    """The document of a .gltf or .glb (its binary chunk kept for the buffers)."""
    try:
        doc = pygltflib.GLTF2.load(str(path))
    except Exception as exc:  # pygltflib raises many types for data it cannot parse
        raise GltfError("", f"not a glTF 2.0 file ({type(exc).__name__}: {exc})") from None
    if doc is None:
        raise GltfError("", "not a glTF 2.0 file")
    return doc


def _finite(values: list[float] | None, count: int, key: str) -> np.ndarray | None:
    if values is None:
        return None
    if len(values) != count or not all(
        isinstance(x, int | float) and math.isfinite(x) for x in values
    ):
        raise GltfError(key, f"must be {count} finite numbers")
    return np.asarray(values, np.float64)


def node_matrix(node: pygltflib.Node, index: int) -> np.ndarray:
    """A node's local matrix: ``matrix`` (column-major), else T @ R @ S from
    ``translation``, ``rotation`` (a unit quaternion x, y, z, w) and ``scale``."""
    key = f"nodes[{index}]"
    matrix = _finite(node.matrix, 16, f"{key}.matrix")
    if matrix is not None:
        return matrix.reshape(4, 4).T
    t = _finite(node.translation, 3, f"{key}.translation")
    q = _finite(node.rotation, 4, f"{key}.rotation")
    s = _finite(node.scale, 3, f"{key}.scale")
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


def world_matrices(doc: pygltflib.GLTF2) -> dict[int, np.ndarray]:
    """Each node of the shown scene (``scene``, else
    the first, else every root node) to its world matrix, parents first. A node reached
    twice (a cycle, or a node with two parents) is bad input, as glTF 2.0 forbids it."""
    nodes = doc.nodes or []
    if doc.scenes:
        index = doc.scene if isinstance(doc.scene, int) else 0
        if not 0 <= index < len(doc.scenes):
            raise GltfError("scene", f"{index} is not one of the {len(doc.scenes)} scenes")
        roots = list(doc.scenes[index].nodes or [])
        roots_key = f"scenes[{index}].nodes"
    else:
        children = {c for n in nodes for c in (n.children or [])}
        roots = [i for i in range(len(nodes)) if i not in children]
        roots_key = "nodes"
    out: dict[int, np.ndarray] = {}
    stack = [(r, np.eye(4), roots_key) for r in reversed(roots)]
    while stack:
        i, parent, key = stack.pop()
        if not isinstance(i, int) or not 0 <= i < len(nodes):
            raise GltfError(key, f"node {i} does not exist ({len(nodes)} nodes)")
        if i in out:
            raise GltfError(key, f"node {i} is reached twice (a cycle or two parents)")
        out[i] = parent @ node_matrix(nodes[i], i)
        for c in reversed(nodes[i].children or []):
            stack.append((c, out[i], f"nodes[{i}].children"))
    return out
