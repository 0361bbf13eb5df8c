"""Triangle adjacency of a mesh part, for the geometry stage of render.antialiasing =
"gbaa" (passes/gbuffer_edge.geom): which of a triangle's edges can be a silhouette.

An edge shared by two triangles that both face the camera (or both away) is never a
silhouette; the geometry stage compares the facing of each triangle with its neighbour's
across every edge, which GL_TRIANGLES_ADJACENCY hands it: per triangle six indices, its
vertices at 0, 2, 4 and at 1, 3, 5 the far vertex of the triangle across the edges
0-2, 2-4 and 4-0. Vertices are matched by position (a UV or normal seam splits a vertex
but not the surface); an edge with no neighbour (an open boundary) or with more than one
takes its own first vertex there, a degenerate neighbour the stage treats as a silhouette.
"""

from __future__ import annotations

import numpy as np


def adjacency_indices(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(T * 6,) uint32 GL_TRIANGLES_ADJACENCY indices of the triangle list ``indices``
    ((T * 3,) into ``positions``, (N, 3))."""
    tris = np.asarray(indices, np.int64).reshape(-1, 3)
    welded = _welded(np.asarray(positions, np.float32))
    w = welded[tris]  # (T, 3) position ids
    n = int(welded.max()) + 1 if len(welded) else 1
    start, end = w, np.roll(w, -1, axis=1)  # edge k runs from vertex k to vertex k + 1
    far = np.roll(tris, -2, axis=1)  # the vertex opposite edge k: k + 2
    keys = (start * n + end).reshape(-1)
    twins = (end * n + start).reshape(-1)
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    at = np.searchsorted(sorted_keys, twins)
    at_clamped = np.minimum(at, len(sorted_keys) - 1)
    found = sorted_keys[at_clamped] == twins
    # an edge shared by more than two triangles (non-manifold): no single neighbour
    last = np.searchsorted(sorted_keys, twins, side="right")
    found &= last - at == 1
    neighbour_far = far.reshape(-1)[order[at_clamped]]
    own_start = tris.reshape(-1)
    adjacent = np.where(found, neighbour_far, own_start).reshape(-1, 3)
    out = np.empty((len(tris), 6), np.uint32)
    out[:, 0::2] = tris
    out[:, 1::2] = adjacent
    return out.reshape(-1)


def _welded(positions: np.ndarray) -> np.ndarray:
    """(N,) ids of finite ``positions`` (N, 3), equal where they compare equal (so -0
    and +0 weld), numbered in lexicographic order (x, then y, then z): the inverse
    ``np.unique(positions, axis=0)`` returns, from one lexsort of three columns instead
    of its slower sort of the rows as records."""
    if len(positions) == 0:
        return np.zeros(0, np.int64)
    order = np.lexsort((positions[:, 2], positions[:, 1], positions[:, 0]))
    ranked = positions[order]
    new = np.empty(len(positions), bool)
    new[0] = True
    new[1:] = np.any(ranked[1:] != ranked[:-1], axis=1)
    ids = np.empty(len(positions), np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids
