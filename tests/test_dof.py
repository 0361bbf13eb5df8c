"""RTR4 §9.2 (the camera): thin-lens depth of field (camera.aperture,
camera.focus_distance; scenes/sec2_depth_of_field.toml). The GLSL circle of confusion and
the gather pass against their float64 twin (app/reference/dof.py), and the properties
that make it a lens blur: a pinhole camera runs no pass, a uniform image stays uniform
whatever the depths, and pixels no disc reaches keep their radiance."""

from __future__ import annotations

import moderngl
import numpy as np

from app.gl.context import GLContext
from app.gl.kernel import run_kernel
from app.gl.shaders import ShaderCache
from app.reference import dof
from app.render.post import DofPass
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.conftest import REPO

SCENE = REPO / "scenes" / "sec2_depth_of_field.toml"


def test_glsl_coc_matches_its_twin(gl: GLContext) -> None:
    """coc_radius in GLSL against the twin: depths from 1 cm to 1 km, the background
    (0), apertures up to 0.5 m, focus 0.5-50 m; within 1e-6 relative (float32), and 0
    exactly on the focus plane."""
    rng = np.random.default_rng(3)
    n = 4000
    z = np.exp(rng.uniform(np.log(0.01), np.log(1000.0), n))
    z[::17] = 0.0
    focus = rng.uniform(0.5, 50.0, n)
    z[5::29] = focus[5::29]
    params = np.stack([rng.uniform(0.0, 0.5, n), focus, rng.uniform(100.0, 2000.0, n)], -1)
    params = params.astype(np.float32).astype(np.float64)
    z = z.astype(np.float32).astype(np.float64)
    out = run_kernel(gl.ctx, ["post/dof.glsl"],
                     "result = vec4(coc_radius(z.x, p.x, p.y, p.z, 12.0));",
                     {"z": z, "p": params})[:, 0]  # fmt: skip
    twin = dof.coc_radius(z, params[:, 0], params[:, 1], params[:, 2], 12.0)
    assert np.abs(out - twin).max() <= 1e-6 * np.maximum(twin, 1.0).max()
    on_focus = z == params[:, 1]
    assert on_focus.sum() > 50 and np.all(out[on_focus] == 0.0)


def test_pass_matches_its_twin_on_the_scene(gl_egl: GLContext) -> None:
    """The scene's DOF image against dof_gather on the same HDR and depth: within 1e-5 of
    the peak on all but 0.1 % of the pixels, room for a sample whose distance ties with
    its disc's radius to float32 rounding (measured: none beyond 1e-5, max 1.8e-7). The
    blur changes 34 % of the pixels by over 1e-3 of the peak (the sky is uniform, so
    blurring leaves it); pixels that no other disc reaches (3.9 %) keep their radiance
    to 3.6e-8 of the peak."""
    loaded = load_scene(SCENE)
    cam = loaded.scene.camera
    r = Renderer(gl_egl, loaded)
    try:
        assert r.dof is not None
        r.render()
        lit = r.lighting.read()
        out = r.read_hdr()
        depth = r.read_gbuffer().depth
    finally:
        r.release()
    h = lit.shape[0]
    scale = dof.pixels_per_radian(cam.fov_y, h)
    twin = dof.dof_gather(lit, depth, cam.aperture, cam.focus, scale)
    peak = np.abs(twin).max()
    err = np.abs(out - twin).max(axis=-1)
    assert (err > 1e-5 * peak).mean() < 1e-3
    # The blur is real: most pixels change.
    changed = np.abs(out - lit).max(axis=-1) > 1e-3 * peak
    assert changed.mean() > 0.25
    untouched = np.abs(twin - lit).max(axis=-1) == 0.0
    assert untouched.sum() > 1000
    assert np.abs(out[untouched] - lit[untouched]).max() <= 1e-6 * peak


def test_sparse_gather_is_close_to_the_dense_one(gl_egl: GLContext) -> None:
    """The pass samples 128 of the 440 pixels within its 12 px reach. Against the dense
    gather over all 440 (the twin with all_offsets()), measured on the scene: relative
    RMSE 1.3 % and mean FLIP 0.012 of the tone-mapped images, where the pinhole image is
    13.8 % and 0.075 away from it."""
    import flip_evaluator as flip

    from app.reference.tonemap import post_process

    loaded = load_scene(SCENE)
    cam = loaded.scene.camera
    r = Renderer(gl_egl, loaded)
    try:
        r.render()
        lit, out, depth = r.lighting.read(), r.read_hdr(), r.read_gbuffer().depth
    finally:
        r.release()
    scale = dof.pixels_per_radian(cam.fov_y, lit.shape[0])
    dense = dof.dof_gather(lit, depth, cam.aperture, cam.focus, scale, dof.all_offsets())

    def display(x: np.ndarray) -> np.ndarray:
        return post_process(x, cam.exposure, loaded.scene.render.tonemap).astype(np.float32)

    def rel_rmse(x: np.ndarray) -> float:
        return float(np.sqrt(np.mean((x - dense) ** 2) / np.mean(dense**2)))

    sparse_flip = flip.evaluate(display(dense), display(out), "LDR")[1]
    pinhole_flip = flip.evaluate(display(dense), display(lit), "LDR")[1]
    assert rel_rmse(out) < 0.03 and sparse_flip < 0.02
    assert rel_rmse(lit) > 4 * rel_rmse(out) and pinhole_flip > 4 * sparse_flip


def test_uniform_radiance_stays_uniform_whatever_the_depths(gl_egl: GLContext) -> None:
    """A constant image through the pass with random depths (and background) is the same
    constant to float32 rounding: the gather is a normalised weighted average."""
    ctx = gl_egl.ctx
    w, h = 96, 64
    rng = np.random.default_rng(9)
    depth = rng.uniform(0.5, 30.0, (h, w)).astype(np.float32)
    depth[rng.uniform(size=(h, w)) < 0.1] = 0.0
    hdr_tex = ctx.texture((w, h), 4, np.tile([[0.3, 1.7, 42.0, 1.0]], (w * h, 1))
                          .astype(np.float32).tobytes(), dtype="f4")  # fmt: skip
    depth_tex = ctx.texture((w, h), 2, np.stack([depth, np.zeros_like(depth)], -1)
                            .tobytes(), dtype="f4")  # fmt: skip
    shaders = ShaderCache(ctx)
    dof_pass = DofPass(ctx, shaders, (w, h), 0.4, 4.0, 40.0)
    try:
        for tex in (hdr_tex, depth_tex):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        dof_pass.run(hdr_tex, depth_tex)
        out = dof_pass.read()
    finally:
        for obj in (dof_pass, hdr_tex, depth_tex, shaders):
            obj.release()
    assert np.abs(out / np.array([0.3, 1.7, 42.0]) - 1.0).max() <= 1e-6


def test_a_pinhole_camera_runs_no_pass(gl_egl: GLContext) -> None:
    """Aperture 0 (the default): no DOF pass is built and the image is the lighting's."""
    loaded = load_scene(SCENE)
    camera = loaded.scene.camera.model_copy(update={"aperture": 0.0})
    pinhole = type(loaded)(loaded.scene.model_copy(update={"camera": camera}), loaded.path)
    r = Renderer(gl_egl, pinhole)
    try:
        assert r.dof is None
        r.render()
        assert np.array_equal(r.read_hdr(), r.lighting.read())
    finally:
        r.release()
