"""The float64 ray-caster (app/reference/raycast.py) against closed forms, and the renderer
against the ray-caster.

The closed forms are computed here the textbook way (the naive quadratic, the sphere's
normal (p - c) / r), independently of the ray-caster's stable quadratic and model-matrix
frames, on a camera at the origin looking down -Z.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from app.bench.raycast import analytic_scenes, five_spheres, raycast_errors
from app.common.camera import CameraFrame
from app.common.lights import LightType, PunctualLight
from app.common.models import DEFAULT_MODEL, ModelParams
from app.common.primitives import Primitive
from app.frame.raycast import reference_scene
from app.reference.material import Surface
from app.reference.raycast import (
    MIXED,
    NO_HIT,
    PrimitiveMaterial,
    cast,
    interior_mask,
    intersect_sphere,
    render_reference,
)
from app.scene.loader import load_scene, parse_scene
from app.scene.model import AREA_LIGHT_TYPES
from tests.agreement import without_shadows
from tests.conftest import REPO

SIZE = (41, 31)  # odd: the middle pixel's ray is the view axis
TAN = math.tan(math.radians(30.0) / 2.0)


def camera(position: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> CameraFrame:
    """At ``position`` looking down -Z, 30 degree vertical field of view."""
    w, h = SIZE
    return CameraFrame(np.asarray(position, float), np.eye(3), (TAN * w / h, TAN), 0.05, 100.0)


def translate(x: float, y: float, z: float, scale: tuple[float, float, float] = (1, 1, 1)):
    m = np.diag([*scale, 1.0])
    m[:3, 3] = (x, y, z)
    return m


def ray(col: int, row: int) -> np.ndarray:
    """The ray through pixel (col, row) of ``camera()``, written out by hand."""
    w, h = SIZE
    x = ((col + 0.5) / w * 2.0 - 1.0) * TAN * w / h
    y = (1.0 - (row + 0.5) / h * 2.0) * TAN
    return np.array([x, y, -1.0])


LAMBERT = PrimitiveMaterial(
    Surface(np.array([0.6, 0.4, 0.2]), 0.0, 0.5, 0.04), ModelParams(), DEFAULT_MODEL
)
SUN = PunctualLight(LightType.DIRECTIONAL, np.zeros(3), np.array([0.0, 0.0, -1.0]), np.full(3, 2.0))


def test_sphere_depth_and_normal_by_hand():
    centre, r = np.array([0.0, 0.0, -5.0]), 1.0
    hits = cast([Primitive("sphere", translate(*centre), radius=r)], camera(), SIZE)
    mid = (SIZE[1] // 2, SIZE[0] // 2)
    assert hits.ids[mid] == 0
    assert hits.depth[mid] == pytest.approx(4.0, abs=1e-12)
    assert np.allclose(hits.n[mid], [0.0, 0.0, 1.0], atol=1e-12)
    covered = np.argwhere(hits.covered)
    assert len(covered) > 50
    for row, col in covered[:: max(1, len(covered) // 40)]:
        d = ray(col, row)
        # a t^2 + b t + c = 0 from |t d - centre|^2 = r^2, the near root
        a, b, c = d @ d, -2.0 * d @ centre, centre @ centre - r * r
        t = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
        assert hits.depth[row, col] == pytest.approx(t, rel=1e-12)
        p = t * d
        assert np.allclose(hits.p[row, col], p, atol=1e-12)
        assert np.allclose(hits.n[row, col], (p - centre) / r, atol=1e-12)
    # the outline: a pixel is covered where its ray passes within r of the centre
    rows, cols = np.indices(hits.ids.shape)
    d = np.stack([ray(cc, rr) for rr, cc in zip(rows.ravel(), cols.ravel(), strict=True)])
    closest = d * ((d @ centre) / np.sum(d * d, axis=1))[:, None] - centre
    inside = (np.linalg.norm(closest, axis=1) < r).reshape(hits.ids.shape)
    assert np.array_equal(inside, hits.covered)


def test_lambert_sphere_radiance_is_albedo_times_irradiance_times_cosine():
    centre = np.array([0.3, -0.2, -6.0])
    img = render_reference(
        [Primitive("sphere", translate(*centre), radius=1.2)], [LAMBERT], camera(), SIZE,
        [SUN], np.zeros(3), terms="diffuse",
    )  # fmt: skip
    hits = cast([Primitive("sphere", translate(*centre), radius=1.2)], camera(), SIZE)
    cos = np.clip(hits.n @ -SUN.direction, 0.0, None)
    want = LAMBERT.surface.base_color * SUN.color * cos[..., None]
    assert img.covered.sum() > 50
    assert np.allclose(img.hdr[img.covered], want[img.covered], rtol=1e-12, atol=1e-15)
    assert np.all(img.hdr[~img.covered] == 0.0)


def test_ellipsoid_by_non_uniform_scale():
    scale = (2.0, 0.5, 1.0)
    centre = np.array([0.0, 0.0, -8.0])
    hits = cast([Primitive("sphere", translate(*centre, scale), radius=1.0)], camera(), SIZE)
    assert hits.covered.sum() > 50
    q = (hits.p[hits.covered] - centre) / scale  # back on the unit sphere
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    # the gradient of (x/2)^2 + (y/0.5)^2 + z^2: the normal the inverse transpose gives
    grad = (hits.p[hits.covered] - centre) / np.square(scale)
    assert np.allclose(hits.n[hits.covered], grad / np.linalg.norm(grad, axis=1)[:, None])
    # the tangent lies in the surface
    assert np.allclose(np.sum(hits.t[hits.covered] * hits.n[hits.covered], axis=1), 0.0, atol=1e-12)
    # 4x as wide as it is high on the screen
    rows, cols = np.nonzero(hits.covered)
    assert (cols.max() - cols.min() + 1) > 3 * (rows.max() - rows.min() + 1)


def test_camera_inside_a_sphere_sees_nothing_of_it():
    sphere = [Primitive("sphere", translate(0.0, 0.0, -0.5), radius=1.0)]
    assert not cast(sphere, camera(), SIZE).covered.any()
    # just outside it, it fills the middle of the view
    assert cast(sphere, camera((0.0, 0.0, 0.6)), SIZE).covered.any()


def test_far_root_is_not_a_hit():
    # origin inside: the near root is behind the camera, the far one (back face) in front
    t = intersect_sphere(1.0, np.zeros(3), np.array([[0.0, 0.0, -1.0]]), 0.05, 100.0)
    assert np.isinf(t[0])


def test_stable_quadratic_far_from_a_small_sphere():
    # 1e6 m away, radius 1e-3: b^2 - a c loses every digit; the closest-point form does not
    o = np.array([0.0, 0.0, 1e6])
    d = np.array([[0.0, 5e-10, -1.0]])
    t = intersect_sphere(1e-3, o, d, 0.05, 1e7)
    y = 5e-10 * 1e6  # the ray passes 5e-4 from the centre
    want = 1e6 - math.sqrt(1e-6 - y * y)
    assert t[0] == pytest.approx(want, rel=1e-12)


def test_plane_is_two_sided_and_faces_the_viewer():
    rot = np.eye(4)
    rot[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # +Y -> +Z: facing the camera
    for sign in (1.0, -1.0):
        m = translate(0.0, 0.0, -4.0) @ rot
        m[:3, 1] *= sign  # the other face towards the camera
        m[:3, 2] *= sign  # (keeping a rotation)
        hits = cast([Primitive("plane", m, size=(2.0, 1.0))], camera(), SIZE)
        assert hits.covered.sum() > 20
        assert np.allclose(hits.n[hits.covered], [0.0, 0.0, 1.0])
        assert np.allclose(hits.depth[hits.covered], 4.0)
        uv = hits.uv[hits.covered]
        assert uv.min() >= 0.0 and uv.max() <= 1.0
        # the rectangle is 2 m wide, 1 m high: outside it, nothing
        rows, cols = np.nonzero(hits.covered)
        assert (cols.max() - cols.min() + 1) > 1.7 * (rows.max() - rows.min() + 1)
    lit_from_behind = PunctualLight(
        LightType.DIRECTIONAL, np.zeros(3), np.array([0.0, 0.0, 1.0]), np.ones(3)
    )
    img = render_reference(
        [Primitive("plane", translate(0.0, 0.0, -4.0) @ rot, size=(2.0, 1.0))], [LAMBERT],
        camera(), SIZE, [lit_from_behind], np.zeros(3),
    )  # fmt: skip
    assert np.all(img.hdr[img.covered] == 0.0)  # the light is on the far side


def test_nearest_primitive_wins():
    near = Primitive("sphere", translate(0.0, 0.0, -5.0), radius=1.0)
    far = Primitive("sphere", translate(0.5, 0.0, -7.0), radius=2.0)
    for prims, front in (([near, far], 0), ([far, near], 1)):
        hits = cast(prims, camera(), SIZE)
        assert hits.ids[SIZE[1] // 2, SIZE[0] // 2] == front
        assert {0, 1} <= set(np.unique(hits.ids))


def test_interior_mask_keeps_pixels_two_away_from_any_boundary():
    ids = np.full((12, 12), NO_HIT)
    ids[1:11, 1:7] = 0
    ids[1:11, 7:11] = 1
    inner = interior_mask(ids, margin=2)
    assert np.array_equal(np.nonzero(inner[5])[0], [3, 4])  # 2 from the edge and from 1
    assert not inner[:, 7:].any()  # primitive 1 is only 4 wide
    assert inner[3:9, 3:5].all() and inner.sum() == 12
    assert interior_mask(ids, margin=1)[5, 8:10].all()


def test_supersampled_pixels_average_their_samples():
    sphere = [Primitive("sphere", translate(0.3, 0.1, -5.0), radius=1.0)]
    w, h = SIZE
    # the frame of an image twice the size is the same: its tangents depend on the aspect
    big = render_reference(sphere, [LAMBERT], camera(), (2 * w, 2 * h), [SUN], np.zeros(3))
    two = render_reference(sphere, [LAMBERT], camera(), SIZE, [SUN], np.zeros(3), supersample=2)
    want = big.hdr.reshape(h, 2, w, 2, 3).mean(axis=(1, 3))  # each pixel's 2x2 block
    assert np.allclose(two.hdr, want, rtol=1e-12, atol=0.0)
    assert (two.ids == MIXED).any() and (two.ids == 0).any()  # the outline, the inside
    assert np.array_equal(two.covered, big.covered.reshape(h, 2, w, 2).any(axis=(1, 3)))


def scene(objects: list[dict], materials: dict | None = None, **camera: object):
    data = {
        "materials": materials or {"m": {"base_color": [0.5, 0.5, 0.5]}},
        "lights": [{"type": "directional", "direction": [0, -1, -1]}],
        "objects": objects,
        "camera": {"position": [0, 0, 5], **camera},
    }
    return parse_scene(data, REPO / "scenes" / "t.toml")


@pytest.mark.parametrize(
    ("objects", "materials", "cam", "message"),
    [
        ([{"shape": "box", "material": "m", "name": "crate"}], None, {}, "objects[0] ('crate')"),
        ([{"shape": "mesh", "file": "meshes/teapot.obj"}], None, {}, "shape 'mesh'"),
        (
            [{"shape": "sphere", "material": "m"}],
            {"m": {"normal_map": "textures/bumpy_normal.png"}},
            {},
            "materials.m: the ray-caster takes no texture maps (normal_map)",
        ),
        ([{"shape": "sphere", "material": "m"}], None, {"aperture": 0.1}, "camera.aperture"),
        (
            [{"shape": "sphere", "material": "m"}],
            {"m": {"alpha": 0.5, "alpha_mode": "blend"}},
            {},
            "materials.m: the ray-caster takes no emission, alpha mask or blend (alpha_mode)",
        ),
    ],
)
def test_reference_scene_refuses_what_it_cannot_do(objects, materials, cam, message):
    loaded = scene(objects, materials, **cam)
    with pytest.raises(ValueError, match=re.escape(message)):
        reference_scene(loaded, (16, 9))


def test_reference_scene_of_a_sphere_and_a_floor():
    loaded = scene(
        [
            {"shape": "sphere", "material": "m", "radius": 1.0},
            {"shape": "plane", "material": "m", "size": [6, 6], "position": [0, -1, 0]},
        ]
    )
    img = reference_scene(loaded, (64, 36))
    assert set(np.unique(img.ids)) == {NO_HIT, 0, 1}
    assert img.interior().sum() > 200
    assert np.all(np.isfinite(img.hdr)) and img.hdr[img.covered].max() > 0.0


# The renderer against the ray-caster, the five spheres at 320x180 on interior
# pixels. Measured on llvmpipe at 640x360 (docs/accuracy.md): subdivisions 6 + f32 gives
# median 4.1e-5, p99 5.3e-4. The bounds below are what the tessellated spheres meet today.
# The accuracy targets for the whole pipeline at the DEFAULT settings (analytic spheres, the
# default G-buffer encoding), interior pixels: docs/accuracy.md.
TARGET_MEDIAN = 1e-5
TARGET_P99 = 1e-4
TARGET_FLIP = 1e-3
# A scene with an area light: its LTC against the exact integral over the light
# (docs/area_lights.md, "Error against the truth"): median, 99th percentile, mean FLIP.
AREA_TARGETS = (1e-5, 0.12, 6e-3)


@pytest.mark.parametrize("point_lights", [False, True], ids=["directional", "point"])
def test_renderer_at_default_settings_meets_the_targets(gl_egl, point_lights):
    """The renderer as a user gets it against the ray-caster. Icospheres miss it by far
    (subdivision 6 with f32: median 3.7e-5, p99 4.8e-4 at this size), and so do the
    analytic spheres with an f16 G-buffer (median 4.4e-4); the coverage is exact at pixel
    centres, where an icosphere's polygonal outline is not."""
    errors = raycast_errors(gl_egl, five_spheres(point_lights=point_lights), (320, 180))
    assert errors["median"] <= TARGET_MEDIAN, errors
    assert errors["p99"] <= TARGET_P99, errors
    assert errors["flip_mean"] <= TARGET_FLIP, errors
    assert errors["coverage_mismatch"] == 0.0, errors


def test_the_targets_fail_a_tessellated_or_half_float_pipeline(gl_egl):
    """The test above can fail: the icosphere of subdivision 6 misses the p99 target, the
    analytic sphere through an f16 G-buffer the median, and the outline of the default
    icosphere (subdivision 4) the coverage."""
    mesh = raycast_errors(gl_egl, five_spheres(6, "f32"), (320, 180), flip=False)
    assert mesh["p99"] > TARGET_P99, mesh
    coarse = raycast_errors(gl_egl, five_spheres(4, "f32"), (320, 180), flip=False)
    assert coarse["coverage_mismatch"] > 0.0, coarse
    half = raycast_errors(gl_egl, five_spheres(None, "f16"), (320, 180), flip=False)
    assert half["median"] > TARGET_MEDIAN, half


def _analytic_scenes() -> list:
    """The bundled scenes the ray-caster takes whose spheres are all analytic (stress.toml
    keeps two icospheres of subdivision 0 and 1 on purpose), punctual lights or a uniform
    environment (``analytic_scenes``). Scenes lit by an image, sky or studio environment
    are left to the image-based lighting's own tests: the split sum is an approximation by
    design, its error against brute force measured in tests/test_ibl_reference.py and
    tabulated in docs/ibl.md (up to tens of percent at grazing angles), far above these
    targets for an exact pipeline."""
    return analytic_scenes(REPO / "scenes", environments=True)


@pytest.mark.parametrize("path", _analytic_scenes(), ids=lambda p: p.stem)
def test_bundled_scene_meets_the_targets(gl_egl, path):
    """Every screenshot scene made of analytic primitives, at its own settings (160 px
    wide), against the ray-caster: the accuracy targets hold for all of them, the far
    cameras (sec1_*, sec11_*, sec12_*: 300 m away) and every BRDF model included.
    Shadows are switched off on both sides: a shadow map's filtered edge is not the shadow
    rays' hard one (mean FLIP 0.0022 on scenes/shadows.toml with them), and
    tests/test_shadows.py measures shadows by lit/unlit state instead (docs/shadows.md)."""
    _meets_the_targets(gl_egl, without_shadows(load_scene(path)))


def test_the_showcase_under_its_punctual_lights_meets_the_targets(gl_egl):
    """The showcase (analytic spheres on a floor under every punctual light type) is lit
    by the studio too, so ``analytic_scenes`` leaves it out; its punctual lights alone,
    the environment removed, meet the targets as every scene above does."""
    loaded = without_shadows(load_scene(REPO / "scenes" / "showcase.toml"))
    assert loaded.scene.environment is not None and loaded.scene.environment.source == "studio"
    loaded = loaded.with_scene(loaded.scene.model_copy(update={"environment": None}))
    _meets_the_targets(gl_egl, loaded)


def _meets_the_targets(gl, loaded) -> None:
    """``loaded`` at its own settings, 160 px wide, against the ray-caster."""
    render = loaded.scene.render
    size = (160, max(8, round(160 * render.height / render.width)))
    errors = raycast_errors(gl, loaded, size)
    median, p99, flip_mean = TARGET_MEDIAN, TARGET_P99, TARGET_FLIP
    if any(light.type in AREA_LIGHT_TYPES for light in loaded.scene.lights):
        # linearly transformed cosines against the exact integral (docs/area_lights.md)
        median, p99, flip_mean = AREA_TARGETS
    assert errors["median"] <= median, errors
    assert errors["p99"] <= p99, errors
    assert errors["flip_mean"] <= flip_mean, errors
    assert errors["coverage_mismatch"] == 0.0, errors
