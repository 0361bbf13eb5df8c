"""Tests for the Utah teapot generator (app/assets/teapot.py) and its checked-in OBJ.

The OBJ under scenes/meshes is generated, not hand-edited; comparing it with a fresh
build keeps the file and the generator from drifting apart.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from app.assets.teapot import PATCHES, SEGMENTS, VERTICES, build_teapot, write_obj

OBJ_PATH = Path(__file__).resolve().parents[1] / "scenes" / "meshes" / "teapot.obj"


@pytest.fixture(scope="module")
def small() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A coarse build: cheap, yet every patch still has interior vertices."""
    return build_teapot(segments=4)


def _read_obj_normals(path: Path) -> np.ndarray:
    """The ``vn`` rows of an OBJ (trimesh may recompute normals, so parse them here)."""
    rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("vn ")]
    return np.asarray(rows, dtype=np.float64)


def test_patch_table_shape() -> None:
    assert len(PATCHES) == 32
    assert all(len(patch) == 16 for patch in PATCHES)
    assert len(VERTICES) == 306
    assert min(min(p) for p in PATCHES) == 1
    assert max(max(p) for p in PATCHES) == 306


def test_finite_and_unit_normals(small: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    vertices, normals, faces = small
    assert vertices.shape == normals.shape
    assert vertices.shape[1] == 3
    assert faces.shape[1] == 3
    assert np.isfinite(vertices).all()
    assert np.isfinite(normals).all()
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    assert faces.min() >= 0
    assert faces.max() < len(vertices)


def test_no_degenerate_faces(small: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    vertices, _, faces = small
    assert (faces[:, 0] != faces[:, 1]).all()
    assert (faces[:, 1] != faces[:, 2]).all()
    assert (faces[:, 0] != faces[:, 2]).all()
    tri = vertices[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert area.min() > 0.0


def test_outward_orientation(small: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    vertices, normals, faces = small
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.is_winding_consistent
    assert mesh.volume > 0.0
    # Our own signed volume (divergence theorem), independent of trimesh.
    tri = vertices[faces]
    signed = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    assert signed > 0.0
    # Analytic vertex normals agree with the winding: on average, per face.
    agreement = np.einsum("ij,ij->i", mesh.face_normals, normals[faces].mean(axis=1))
    assert (agreement > 0.0).all()


def test_y_up_unit_height(small: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    vertices, normals, _ = small
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    assert lo[1] == pytest.approx(0.0, abs=1e-9)
    assert hi[1] - lo[1] == pytest.approx(1.0, abs=1e-9)
    # Spout along +x, handle along -x, mirror-symmetric in z, lid axis at x = z = 0.
    assert hi[0] > 1.0 > -lo[0] > 0.9
    assert hi[2] == pytest.approx(-lo[2], abs=1e-9)
    # The poles (knob apex, bottom centre) get the axis as their normal.
    top = np.argmax(vertices[:, 1])
    np.testing.assert_allclose(vertices[top], [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(normals[top], [0.0, 1.0, 0.0], atol=1e-9)
    bottom = np.argmin(np.linalg.norm(vertices, axis=1))
    np.testing.assert_allclose(vertices[bottom], [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(normals[bottom], [0.0, -1.0, 0.0], atol=1e-9)


def test_write_obj_round_trip(
    small: tuple[np.ndarray, np.ndarray, np.ndarray], tmp_path: Path
) -> None:
    vertices, normals, faces = small
    path = tmp_path / "sub" / "teapot_small.obj"
    write_obj(path, vertices, normals, faces)
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temp file left
    mesh = trimesh.load(path, process=False, force="mesh")
    np.testing.assert_allclose(mesh.vertices, vertices, atol=1e-6)
    np.testing.assert_array_equal(mesh.faces, faces)
    np.testing.assert_allclose(_read_obj_normals(path), normals, atol=1e-6)


def test_checked_in_obj_matches_generator() -> None:
    assert OBJ_PATH.is_file(), "run `python -m app.assets.teapot` to generate it"
    assert OBJ_PATH.stat().st_size < 1_500_000
    vertices, normals, faces = build_teapot(segments=SEGMENTS)
    mesh = trimesh.load(OBJ_PATH, process=False, force="mesh")
    assert len(mesh.vertices) == len(vertices)
    assert len(mesh.faces) == len(faces)
    np.testing.assert_allclose(mesh.vertices, vertices, atol=1e-6)
    np.testing.assert_array_equal(mesh.faces, faces)
    np.testing.assert_allclose(_read_obj_normals(OBJ_PATH), normals, atol=1e-6)
