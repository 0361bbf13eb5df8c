"""Analytic spheres in the G-buffer (glsl/geometry/analytic.glsl): the exact surface under
every pixel centre, checked against closed-form geometry computed here in float64.

What a tessellated sphere gets wrong and these tests would catch: the normal (interpolated
across facets), the position (the chord lies inside the sphere), the silhouette (a polygon),
depth-testing against other surfaces, and texture filtering across the longitude seam.
"""

from __future__ import annotations

import copy

import numpy as np
from PIL import Image

from app.bench.scenes import load
from app.reference.encoding import oct_decode
from app.reference.raycast import camera_rays
from app.render.renderer import Renderer
from app.scene.loader import load_scene

SPHERE = {"shape": "sphere", "radius": 0.5, "position": [0.1, 0.45, -0.2], "material": "m"}
SCENE = {
    "camera": {"position": [0.4, 1.1, 2.6], "target": [0.0, 0.4, 0.0], "fov_y": 35.0},
    "render": {"width": 160, "height": 120, "gbuffer": "f32"},
    "lights": [{"type": "directional", "direction": [-0.3, -1.0, -0.5], "intensity": 2.0}],
    "materials": {"m": {"base_color": [0.7, 0.5, 0.3], "roughness": 0.4}},
    "objects": [SPHERE],
}


def _scene(**changes: object) -> dict:
    data = copy.deepcopy(SCENE)
    data.update(copy.deepcopy(changes))
    return data


def _rays(r: Renderer) -> np.ndarray:
    """(H, W, 3) world directions through the pixel centres, rows top to bottom, whose
    component along the view axis is 1 (so the ray parameter is the view depth)."""
    return camera_rays(r.camera, *r.render_size)


def _sphere_hits(r: Renderer, centre, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form ray-sphere: (covered (H, W), near t (H, W), nan where missed)."""
    d = _rays(r)
    o = np.asarray(r.camera.position) - np.asarray(centre, np.float64)
    a = np.sum(d * d, axis=-1)
    b = d @ o
    c = o @ o - radius * radius
    disc = b * b - a * c
    t = np.where(disc >= 0.0, (-b - np.sqrt(np.maximum(disc, 0.0))) / a, np.nan)
    return disc >= 0.0, t


def _render(gl, data: dict) -> Renderer:
    r = Renderer(gl, load(data))
    r.render()
    return r


def _positions(r: Renderer, g) -> np.ndarray:
    return r.camera.position + g.depth[..., None] * _rays(r)


def test_sphere_surface_is_exact(gl_egl):
    """Depth, normal and coverage of an analytic sphere against the closed form: every
    covered pixel lies on the sphere (|p - c| = r) with the sphere's normal. A tessellated
    sphere fails both (its chords lie up to ~1e-3 r inside, its interpolated normals err by
    ~1e-3 rad at subdivision 4), which the last part shows."""
    r = _render(gl_egl, _scene())
    try:
        g = r.read_gbuffer()
        covered, t = _sphere_hits(r, SPHERE["position"], SPHERE["radius"])
        assert g.covered.sum() > 2000
        # Coverage at pixel centres: equal except where the ray grazes the sphere so
        # closely that float32 cannot tell (within 1e-4 of the radius).
        d = _rays(r)
        o = np.asarray(r.camera.position) - np.asarray(SPHERE["position"])
        closest = np.linalg.norm(
            o + (-(d @ o) / np.sum(d * d, -1))[..., None] * d, axis=-1
        )  # the ray's distance from the centre
        grazing = np.abs(closest - SPHERE["radius"]) < 1e-4 * SPHERE["radius"]
        assert np.array_equal(g.covered[~grazing], covered[~grazing])
        cov = g.covered
        # Near the silhouette the depth is ill-conditioned (dt/dr grows as the ray grazes):
        # 2e-6 within 98 % of the radius, 2e-5 in the outer rim.
        inner = cov & (closest < 0.98 * SPHERE["radius"])
        np.testing.assert_allclose(g.depth[inner], t[inner], rtol=2e-6)
        np.testing.assert_allclose(g.depth[cov], t[cov], rtol=2e-5)
        p = _positions(r, g)[cov]
        n_exact = p - SPHERE["position"]
        n_exact /= np.linalg.norm(n_exact, axis=-1, keepdims=True)
        np.testing.assert_allclose(
            np.linalg.norm(p - SPHERE["position"], axis=-1), SPHERE["radius"], rtol=2e-6
        )

        n = oct_decode(g.normal[cov][:, :2].astype(np.float64))
        angle = np.arccos(np.clip(np.sum(n * n_exact, axis=-1), -1.0, 1.0))
        assert angle.max() < 3e-6, angle.max()
    finally:
        r.release()
    mesh = _render(gl_egl, _scene(objects=[{**SPHERE, "subdivisions": 4}]))
    try:
        g = mesh.read_gbuffer()
        cov = g.covered
        p = _positions(mesh, g)[cov]
        dist = np.linalg.norm(p - SPHERE["position"], axis=-1) / SPHERE["radius"]
        assert np.abs(dist - 1.0).max() > 1e-4  # the facets lie inside the sphere
    finally:
        mesh.release()


def test_scaled_sphere_is_an_ellipsoid(gl_egl):
    """A non-uniform scale makes an ellipsoid: its pixels satisfy the ellipsoid's equation
    and carry its normal (the gradient of that equation, not the scaled sphere normal)."""
    scale = [1.4, 0.6, 0.9]
    obj = {**SPHERE, "scale": scale, "rotation": [0.0, 30.0, 0.0]}
    r = _render(gl_egl, _scene(objects=[obj]))
    try:
        g = r.read_gbuffer()
        cov = g.covered
        assert cov.sum() > 1000
        part = r.frame.parts[0]
        inv = np.linalg.inv(part.model)
        p = _positions(r, g)[cov]
        q = p @ inv[:3, :3].T + inv[:3, 3]  # object space: on the sphere of radius 0.5
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), SPHERE["radius"], rtol=2e-6)
        n_exact = (q / SPHERE["radius"]) @ inv[:3, :3]  # inverse transpose
        n_exact /= np.linalg.norm(n_exact, axis=-1, keepdims=True)
        n = oct_decode(g.normal[cov][:, :2].astype(np.float64))
        assert np.arccos(np.clip(np.sum(n * n_exact, -1), -1, 1)).max() < 3e-6
    finally:
        r.release()


def test_depth_test_against_meshes_and_spheres(gl_egl):
    """gl_FragDepth puts the analytic surface where it is: a sphere sunk into a floor shows
    only above it, and two overlapping spheres meet on their intersection circle."""
    objects = [
        {"shape": "plane", "size": [6.0, 6.0], "material": "floor"},
        {**SPHERE, "position": [0.0, 0.2, 0.0]},  # sunk 0.3 m into the floor
        {**SPHERE, "position": [0.45, 0.45, 0.1], "material": "other"},
    ]
    materials = {
        **SCENE["materials"],
        "floor": {"base_color": [0.2, 0.2, 0.2]},
        "other": {"base_color": [0.1, 0.6, 0.2]},
    }
    r = _render(gl_egl, _scene(objects=objects, materials=materials))
    try:
        g = r.read_gbuffer()
        cov_a, t_a = _sphere_hits(r, objects[1]["position"], 0.5)
        cov_b, t_b = _sphere_hits(r, objects[2]["position"], 0.5)
        d = _rays(r)
        cam = np.asarray(r.camera.position)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = np.where(d[..., 1] < 0.0, -cam[1] / d[..., 1], np.nan)
        ts = np.stack([t_floor, np.where(cov_a, t_a, np.nan), np.where(cov_b, t_b, np.nan)])
        nearest = np.nanargmin(np.where(np.isnan(ts), np.inf, ts), axis=0)
        # The surfaces told apart by their base colours (the material table's rows are
        # per model, shared by all three).
        colours = np.array([materials[o["material"]]["base_color"] for o in objects])
        want = nearest
        # Away from the edges where two surfaces meet within float32 depth (1e-3 m here)
        t_sorted = np.sort(np.where(np.isnan(ts), 1e30, ts), axis=0)
        clear = (t_sorted[1] - t_sorted[0]) > 1e-3
        clear &= g.covered
        got = np.argmin(
            np.linalg.norm(g.base_color[..., None, :3] - colours[None, None], axis=-1), axis=-1
        )
        assert clear.sum() > 5000
        assert np.array_equal(got[clear], want[clear])
        assert len(np.unique(got[clear])) == 3
    finally:
        r.release()


def test_camera_inside_a_sphere_sees_nothing_of_it(gl_egl):
    """As a mesh with culled back faces: from inside, the sphere is not drawn (the near
    root lies behind the camera), while a sphere behind it is."""
    cam = {"position": [0.0, 0.5, 0.0], "target": [0.0, 0.5, -3.0], "fov_y": 60.0}
    objects = [
        {**SPHERE, "position": [0.0, 0.5, 0.0], "radius": 1.0},
        {**SPHERE, "position": [0.0, 0.5, -3.0]},
    ]
    r = _render(gl_egl, _scene(camera=cam, objects=objects))
    try:
        g = r.read_gbuffer()
        covered, _ = _sphere_hits(r, objects[1]["position"], 0.5)
        assert g.covered.sum() > 500
        assert np.array_equal(g.covered, covered) or (g.covered != covered).sum() < 8
        depth = g.depth[g.covered]
        assert depth.min() > 2.0  # only the far sphere (2.5 m away) is drawn
    finally:
        r.release()


def _checker(path, size: int = 256, check: int = 8) -> None:
    ij = np.indices((size, size)) // check
    value = np.where((ij[0] + ij[1]) % 2 == 0, 230, 25).astype(np.uint8)
    Image.fromarray(np.stack([value] * 3, -1)).save(path)


def test_texture_seam_has_no_line(gl_egl, tmp_path):
    """The longitude seam (u = 0 | 1, behind the sphere's -Z side) turned to the camera: the
    analytic sphere's texture there matches the 81,920-triangle mesh sphere's (whose seam
    vertices are split), with no line of the coarsest mip where u jumps. Sampling with the
    implicit derivatives puts a grey line along it (seen), which this test fails on. The
    turn is 180.7 degrees, not 180: at 180 the seam falls between two 2x2 pixel quads, where
    no derivative crosses it."""
    _checker(tmp_path / "checker.png")
    text = """
[camera]
position = [0.0, 0.0, 2.2]
target = [0.0, 0.0, 0.0]
fov_y = 40
[render]
width = 200
height = 200
gbuffer = "f32"
[[lights]]
type = "directional"
direction = [0, 0, -1]
[materials.m]
base_color_map = "checker.png"
roughness = 0.5
[[objects]]
shape = "sphere"
material = "m"
rotation = [0, 180.7, 0]
SUBDIV
"""
    shots = []
    for subdiv in ("", "subdivisions = 6"):
        path = tmp_path / f"s{len(shots)}.toml"
        path.write_text(text.replace("SUBDIV", subdiv))
        r = Renderer(gl_egl, load_scene(path))
        try:
            r.render()
            shots.append(r.read_gbuffer().base_color[..., :3].astype(np.float64))
        finally:
            r.release()
    analytic, mesh = shots
    # The seam runs down the image's middle column; compare a band around it, away from
    # the silhouette and the poles.
    band = (slice(60, 140), slice(90, 110))
    diff = np.abs(analytic[band] - mesh[band])
    assert diff.mean() < 0.01, diff.mean()
    assert np.percentile(diff, 99) < 0.15


def test_far_camera_keeps_the_normal(gl_egl):
    """A camera 300 m from a half-metre sphere (sec1's nearly orthographic view): every
    point near the sphere is a difference of two numbers near 300 in float32, which cost
    the normal 1.5e-5 rad (median; 9.6e-5 at worst) before the ray was written around the
    ray through the centre (geometry/analytic.glsl, pixel_ray); with it 3.7e-6 (1.3e-5 at
    worst), what one float32 step of the ray's own direction moves a hit at 300 m."""
    cam = {"position": [0.2, 0.3, 300.0], "target": [0.1, 0.45, -0.2], "fov_y": 0.3,
           "near": 250.0, "far": 350.0}  # fmt: skip
    r = _render(gl_egl, _scene(camera=cam))
    try:
        g = r.read_gbuffer()
        cov = g.covered
        assert cov.sum() > 2000
        centre = np.asarray(SPHERE["position"], np.float64)
        # The exact normal where the pixel's ray meets the sphere (closed form, float64).
        _, t = _sphere_hits(r, centre, SPHERE["radius"])
        p = r.camera.position + t[..., None] * _rays(r)
        n_exact = (p[cov] - centre) / SPHERE["radius"]
        n = oct_decode(g.normal[cov][:, :2].astype(np.float64))
        angle = np.arccos(np.clip(np.sum(n * n_exact, axis=-1), -1.0, 1.0))
        assert np.median(angle) < 6e-6 and angle.max() < 3e-5, angle.max()
    finally:
        r.release()
