"""app/scene/icosphere.py gives trimesh's icosphere without importing trimesh, and the
primitives built on it are the arrays the trimesh-built ones were, bit for bit (so that
no pixel changes)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from app.scene import geometry
from app.scene.icosphere import unit_icosphere


@pytest.mark.parametrize("subdivisions", range(6))
def test_unit_icosphere_is_trimeshs(subdivisions: int) -> None:
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    vertices, faces = unit_icosphere(subdivisions)
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    assert np.array_equal(vertices.view(np.uint64), np.asarray(mesh.vertices).view(np.uint64))
    assert np.array_equal(faces, np.asarray(mesh.faces))
    assert not vertices.flags.writeable and not faces.flags.writeable


def _trimesh_sphere(radius: float, subdivisions: int) -> trimesh.Trimesh:
    """The mesh sphere as geometry.py built it through trimesh before."""
    unit = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    normals = unit.vertices / np.linalg.norm(unit.vertices, axis=1, keepdims=True)
    positions, faces, uv = geometry._sphere_uv(normals, np.asarray(unit.faces))
    mesh = trimesh.Trimesh(positions * radius, faces, vertex_normals=positions, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv)
    return mesh


@pytest.mark.parametrize(("radius", "subdivisions"), [(0.5, 4), (1.7, 2), (1e-20, 1)])
def test_mesh_sphere_vertices_are_unchanged(radius: float, subdivisions: int) -> None:
    got = geometry._interleave(geometry._icosphere(radius, subdivisions))
    want = geometry._interleave(_trimesh_sphere(radius, subdivisions))
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g.view(np.uint8), w.view(np.uint8))


def test_plane_vertices_are_unchanged() -> None:
    sx, sz = 7.0, 2.5
    v = np.array([[-sx, 0, -sz], [-sx, 0, sz], [sx, 0, sz], [sx, 0, -sz]], np.float64)
    normals = np.tile([0.0, 1.0, 0.0], (4, 1))
    mesh = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], vertex_normals=normals, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=[[0, 1], [0, 0], [1, 0], [1, 1]])
    got = geometry._interleave(geometry._plane([14.0, 5.0]))
    want = geometry._interleave(mesh)
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g.view(np.uint8), w.view(np.uint8))


def test_analytic_spheres_share_their_triangles() -> None:
    """The shadow pass takes every analytic sphere's triangles: one build per radius,
    read-only, the arrays the mesh sphere of that radius has."""
    from app.bench.scenes import load

    data = {
        "materials": {"m": {"base_color": [0.5, 0.5, 0.5]}},
        "lights": [{"type": "point", "position": [0.0, 3.0, 0.0], "intensity": 1.0}],
        "objects": [{"shape": "sphere", "radius": 0.6, "material": "m", "position": [x, 0, 0]}
                    for x in (0.0, 2.0)],
    }  # fmt: skip
    a, b = geometry.build_parts(load(data))
    (va, ia), (vb, ib) = a.triangles(), b.triangles()
    assert va is vb and ia is ib
    assert not va.flags.writeable and not ia.flags.writeable
    want = geometry._interleave(geometry._icosphere(0.6, geometry.ICOSPHERE_SUBDIVISIONS))
    assert np.array_equal(va, want[0]) and np.array_equal(ia, want[1])
