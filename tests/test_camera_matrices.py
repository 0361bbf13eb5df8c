"""The camera's view and projection matrices (app/frame/camera.py) against what they
mean: the eye at the origin looking down -Z with the scene's up on +Y, and a pinhole
whose near and far planes land on NDC z = -1 and +1 and whose field of view spans
[-1, 1] in x and y."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from app.frame.camera import projection_matrix, view_matrix


def _camera(position, target, up=(0.0, 1.0, 0.0), fov_y=45.0, near=0.1, far=100.0):
    return SimpleNamespace(
        position=tuple(position), target=tuple(target), up=tuple(up),
        fov_y=fov_y, near=near, far=far,
    )  # fmt: skip


def _apply(m: np.ndarray, p) -> np.ndarray:
    return m @ np.append(np.asarray(p, np.float64), 1.0)


CAMERAS = [
    _camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0)),
    _camera((3.0, 2.0, -4.0), (0.5, -1.0, 2.0)),
    _camera((-7.0, 0.5, 0.25), (1.0, 1.0, 1.0), up=(0.2, 1.0, -0.3)),
    _camera((0.0, -2.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)),  # looking up +Y
]


@pytest.mark.parametrize("cam", CAMERAS)
def test_view_puts_the_eye_at_the_origin_looking_down_minus_z(cam) -> None:
    view = view_matrix(cam)
    rotation = view[:3, :3]
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-14)  # right-handed
    np.testing.assert_allclose(view[3], [0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(_apply(view, cam.position)[:3], 0.0, atol=1e-13)
    distance = np.linalg.norm(np.subtract(cam.target, cam.position))
    np.testing.assert_allclose(_apply(view, cam.target)[:3], [0.0, 0.0, -distance], atol=1e-13)
    above = _apply(view, np.add(cam.position, cam.up))[:3]  # the scene's up: +Y side
    assert above[1] > 0.0 and above[0] == pytest.approx(0.0, abs=1e-13)


@pytest.mark.parametrize("aspect", [1.0, 16 / 9, 0.5])
@pytest.mark.parametrize("fov_y", [20.0, 45.0, 90.0])
def test_projection_maps_the_frustum_onto_the_ndc_cube(aspect: float, fov_y: float) -> None:
    cam = _camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), fov_y=fov_y, near=0.25, far=40.0)
    proj = projection_matrix(cam, aspect)

    def ndc(p):
        clip = _apply(proj, p)
        assert clip[3] == pytest.approx(-p[2])  # w is the depth in front of the eye
        return clip[:3] / clip[3]

    half = math.tan(math.radians(fov_y) / 2.0)
    for depth in (cam.near, 3.0, cam.far):
        corner = ndc((half * aspect * depth, -half * depth, -depth))
        np.testing.assert_allclose(corner[:2], [1.0, -1.0], rtol=1e-14)
    assert ndc((0.0, 0.0, -cam.near))[2] == pytest.approx(-1.0, abs=1e-14)
    assert ndc((0.0, 0.0, -cam.far))[2] == pytest.approx(1.0, abs=1e-14)
    middle = ndc((0.0, 0.0, -3.0))[2]  # perspective depth: hyperbolic in the distance
    expected = (cam.far + cam.near) / (cam.far - cam.near) - 2 * cam.far * cam.near / (
        (cam.far - cam.near) * 3.0
    )
    assert middle == pytest.approx(expected, abs=1e-14)
