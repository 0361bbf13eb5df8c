"""The unit icosphere, without importing trimesh.

``import trimesh`` costs a render its scipy (about a third of a second of a cold start:
docs/performance.md, "Start-up"), and a scene of primitive spheres needs nothing of it
but ``trimesh.creation.icosphere``'s two arrays. ``unit_icosphere`` gives those very
arrays, bit for bit (tests/test_icosphere.py compares them with trimesh's for every
subdivision count a scene uses): trimesh's icosahedron (its ``resources/creation.json``,
read as a file, so that the package is not imported), then per subdivision each edge's
midpoint, numbered as trimesh numbers them, each triangle split in four, and every vertex
moved onto the unit sphere by trimesh's arithmetic. Where that file cannot be read, it
asks trimesh itself.
"""

from __future__ import annotations

import functools
import importlib.util
import json
from pathlib import Path

import numpy as np


def _icosahedron() -> tuple[np.ndarray, np.ndarray] | None:
    """trimesh's icosahedron (vertices float64, faces int64), from its data file, or None
    where trimesh is not installed or keeps the file elsewhere."""
    spec = importlib.util.find_spec("trimesh")  # finds the package without running it
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        path = Path(folder) / "resources" / "creation.json"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))["icosahedron"]
            vertices = np.array(data["vertices"], dtype=np.float64)
            faces = np.array(data["faces"], dtype=np.int64)
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if vertices.shape == (12, 3) and faces.shape == (20, 3):
            return vertices, faces
    return None


def _onto_sphere(vertices: np.ndarray) -> np.ndarray:
    """Every vertex moved along its direction to length 1, by trimesh's arithmetic (the
    length through ``np.dot``, then the difference added), so the floats are its floats."""
    length = np.sqrt(np.dot(vertices**2, [1, 1, 1]))
    direction = vertices / length.reshape((-1, 1))
    return vertices + direction * (1.0 - length).reshape((-1, 1))


def _split(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One subdivision: a vertex at the middle of every edge, appended in the order of the
    edges' (larger, smaller) vertex numbers (trimesh's), and each triangle (a, b, c) with
    midpoints ab, bc, ca replaced by (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape((-1, 2)), axis=1)
    key = (edges[:, 1] << 32) | edges[:, 0]
    _, first, which = np.unique(key, return_index=True, return_inverse=True)
    middle = vertices[edges[first]].mean(axis=1)
    mid = which.reshape((-1, 3)) + len(vertices)  # ab, bc, ca of each face
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    ab, bc, ca = mid[:, 0], mid[:, 1], mid[:, 2]
    children = np.column_stack([a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca])
    return np.vstack((vertices, middle)), children.reshape((-1, 3))


@functools.cache
def unit_icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """``trimesh.creation.icosphere(subdivisions, radius=1.0)``'s vertices (float64) and
    faces (int64), read-only, built once per process and count."""
    base = _icosahedron()
    if base is None:
        import trimesh

        mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
        vertices, faces = np.array(mesh.vertices, np.float64), np.array(mesh.faces, np.int64)
    else:
        vertices, faces = base
        for _ in range(subdivisions):
            vertices, faces = _split(vertices, faces)
            vertices = _onto_sphere(vertices)
        if subdivisions <= 0:
            vertices = _onto_sphere(vertices)
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces
