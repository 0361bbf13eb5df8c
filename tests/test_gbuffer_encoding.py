"""The G-buffer encodings (app/common/gbuffer.py ENCODINGS, docs/gbuffer.md "Encodings"):
the GLSL encode/decode of glsl/common/encoding.glsl against its twin, through a real target
of each storage, and the default setting.

The round trip writes a grid of unit vectors through oct_encode (and snorm_to_unorm for
unorm16) into a target of the storage, reads the texels back, and decodes them with the
GLSL (unorm_to_snorm, oct_decode) and with the float64 twin. Measured on llvmpipe: the
largest angle between a vector and its decoded self (mean in brackets) is 1.9e-7 rad
(4.8e-8) in float32, 6.0e-5 (2.3e-5) in unorm16 and 1.9e-3 (6.0e-4) in float16.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.common.gbuffer import DEFAULT_ENCODING, ENCODINGS, encoding_defines
from app.gl.kernel import run_kernel
from app.reference.encoding import finite_or, oct_decode, oct_encode, unorm_to_snorm
from app.scene.model import RenderSettings

# Largest angular error (rad) each direction storage is held to: a little above the
# measured maximum of the grid below (module docstring).
MAX_ANGLE = {"f32": 3e-7, "unorm16": 7e-5, "f16": 2.5e-3}
DTYPES = {"f32": "f4", "unorm16": "nu2", "f16": "f2"}


def unit_grid(n: int = 4096) -> np.ndarray:
    """A Fibonacci spiral of n unit vectors plus the six axes and the octahedron's seams."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    spiral = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)
    axes = np.concatenate([np.eye(3), -np.eye(3)])
    seams = np.array([[1, 1, 0], [-1, 1, 0], [1, -1, 0], [-1, -1, 0], [1, 0, -1], [0, -1, -1]])
    extra = np.concatenate([axes, seams / np.linalg.norm(seams, axis=-1, keepdims=True)])
    return np.concatenate([spiral, extra])


def store(gl, n: np.ndarray, storage: str) -> np.ndarray:
    """The octahedral coordinates of ``n`` as a target of ``storage`` keeps them, mapped back
    to [-1, 1] (the texels the decode reads, as GBuffer.read gives them)."""
    unorm = storage == "unorm16"
    body = (
        "result.xy = snorm_to_unorm(oct_encode(normalize(n.xyz)));"
        if unorm
        else ("result.xy = oct_encode(normalize(n.xyz));")
    )
    texels = run_kernel(
        gl.ctx, ["common/encoding.glsl"], body, {"n": n}, target_dtype=DTYPES[storage]
    )[:, :2]
    return unorm_to_snorm(texels) if unorm else texels


def angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


@pytest.mark.parametrize("storage", ["f32", "unorm16", "f16"])
def test_round_trip_through_a_target_glsl_against_twin(gl, storage: str) -> None:
    n = unit_grid()
    e = store(gl, n, storage)
    # The GLSL encode agrees with the twin's up to the storage's rounding.
    assert np.abs(e - oct_encode(n)).max() <= {"f32": 1e-6, "unorm16": 1.6e-5, "f16": 5e-4}[storage]
    twin = oct_decode(e)
    # The GLSL decode of the stored texels (from the unorm codes where unorm) agrees with
    # the twin's to float32 precision.
    raw = (e * 32767.0 + 32767.0) / 65535.0 if storage == "unorm16" else e
    body = "result.xyz = oct_decode(%s);" % (
        "unorm_to_snorm(e.xy)" if storage == "unorm16" else "e.xy"
    )
    glsl = run_kernel(gl.ctx, ["common/encoding.glsl"], body, {"e": raw})[:, :3]
    assert np.abs(glsl - twin).max() < 1e-6
    worst = angles(n, twin).max()
    assert worst <= MAX_ANGLE[storage], f"{storage}: {worst:.2e} rad"
    if storage == "unorm16":  # snorm16's grid keeps the axes (floors, box faces) exact
        axes = slice(len(n) - 12, len(n) - 6)
        assert np.array_equal(twin[axes], n[axes])


def test_the_default_encoding_meets_its_bound_and_f16_does_not(gl) -> None:
    """The default's direction storage is held to its bound, which float16 breaks (so the
    bound discriminates: the test fails if the default goes back to f16)."""
    n = unit_grid()
    default_storage = ENCODINGS[DEFAULT_ENCODING][1]
    bound = MAX_ANGLE[default_storage]
    assert angles(n, oct_decode(store(gl, n, default_storage))).max() <= bound
    assert angles(n, oct_decode(store(gl, n, "f16"))).max() > bound


def test_default_setting_is_the_measured_choice() -> None:
    assert DEFAULT_ENCODING == "f32"
    assert RenderSettings().gbuffer == DEFAULT_ENCODING
    assert set(ENCODINGS) >= {"f16", "f32", "unorm16"}
    # Float targets compile exactly as before the encodings existed (no define at all).
    assert encoding_defines("f16") == encoding_defines("f32") == {}
    assert encoding_defines("unorm16") == {"GBUFFER_UNORM_DIRECTIONS": 1}


def test_a_unorm_target_keeps_no_nan(gl) -> None:
    """A unorm target cannot store NaN: the G-buffer pass gives a non-finite value the
    fallback the decode's sanitize_value would give it (finite_or); what the GL itself
    makes of a NaN store is a finite code either way."""
    values = np.array([np.nan, np.inf, -np.inf, 0.25], np.float32)
    body = "result = vec4(finite_or(x.x, 1.0), finite_or(x.x, 0.04), x.x, 0.0);"
    out = run_kernel(gl.ctx, ["common/encoding.glsl"], body, {"x": values}, target_dtype="nu2")
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out[:, 0], np.round(finite_or(values, 1.0) * 65535) / 65535)
    np.testing.assert_allclose(out[:, 1], np.round(finite_or(values, 0.04) * 65535) / 65535)


@pytest.mark.parametrize("encoding", ["f32", "unorm16"])
def test_a_frame_clears_only_what_marks_the_background(gl_egl, encoding: str) -> None:
    """The G-buffer pass clears RT2 and the z-buffer only (docs/performance.md):
    a pixel a surface left keeps stale texels in the other targets, yet ``read`` gives
    it the cleared value, the lighting pass shows the background there, and the frame
    equals a frame drawn into fully cleared targets."""
    from app.bench.scenes import load, many_lights_scene
    from app.render.renderer import Renderer

    size = (64, 36)
    data = many_lights_scene(4, 12.0, size, gbuffer=encoding)
    moved = {**data, "camera": {**data["camera"], "position": [0.0, 4.0, 26.0]}}
    r = Renderer(gl_egl, load(data), size)
    fresh = Renderer(gl_egl, load(moved), size)
    try:
        r.render()
        before = r.read_gbuffer()
        r.set_camera(fresh.scene.camera)  # the surfaces move: some pixels lose theirs
        r.render()
        after, image = r.read_gbuffer(), r.read_hdr()
        fresh.render()
        expected, expected_image = fresh.read_gbuffer(), fresh.read_hdr()
    finally:
        r.release()
        fresh.release()
    left = (before.depth > 0.0) & (after.depth == 0.0)
    assert left.any()  # the test needs pixels whose surface went away
    for name in ("base_color", "normal", "depth", "tangent", "material_id"):
        assert np.array_equal(getattr(after, name), getattr(expected, name)), name
    assert np.array_equal(image, expected_image)


def test_flushing_in_runs_draws_the_same_targets(gl_egl, monkeypatch) -> None:
    """The G-buffer pass draws in runs and flushes between them (app/render/gbuffer.py
    FLUSH_TRIANGLES, DRAW_RUN): with runs of 30 triangles and a flush after each, every
    target equals the one-draw-per-part, one-flush frame's to the bit (a sphere's proxy,
    80 triangles, is drawn in three runs)."""
    import app.render.gbuffer as gbuffer_module
    from app.bench.scenes import load, many_lights_scene
    from app.render.renderer import Renderer, RenderOptions

    size = (96, 54)
    data = many_lights_scene(4, 12.0, size)
    r = Renderer(gl_egl, load(data), size)
    try:
        assert max(len(d.part.indices) // 3 for d in r.gbuffer_pass.drawables) > 60
        r.set_options(RenderOptions(flush_triangles=0))  # one draw per part, no flush between
        r.render()
        whole, whole_image = r.read_gbuffer(), r.read_hdr()
        monkeypatch.setattr(gbuffer_module, "DRAW_RUN", 30)
        r.set_options(RenderOptions(flush_triangles=30))
        r.render()
        runs, runs_image = r.read_gbuffer(), r.read_hdr()
    finally:
        r.release()
    assert (whole.depth > 0.0).mean() > 0.5
    for name in ("base_color", "normal", "depth", "tangent", "material_id"):
        assert np.array_equal(getattr(runs, name), getattr(whole, name)), name
    assert np.array_equal(runs_image, whole_image)


@pytest.mark.parametrize("scene", ["gltf_alpha_blend", "sec2_depth_of_field"])
def test_the_lighting_pass_z_test_keeps_the_image(gl_egl, scene: str) -> None:
    """The lighting pass draws its triangle on the far plane against the G-buffer's
    z-buffer (app/render/lighting.py): the frame equals the one drawn into a target
    without a z-buffer (every pixel runs the shader, the background ones write the
    background themselves, and the background draw, z-tested to them, is left out), and the
    z-buffer is left as the G-buffer pass wrote it, which the blend pass tests its parts
    against (gltf_alpha_blend has blended parts behind and in front of opaque ones)."""
    from pathlib import Path

    from app.render.renderer import Renderer
    from app.scene.loader import load_scene

    path = Path(__file__).resolve().parent.parent / "scenes" / f"{scene}.toml"
    size = (128, 72)
    r = Renderer(gl_egl, load_scene(path), size)
    try:
        r.render()
        tested, tested_ldr = r.read_hdr(), r.read_ldr()
        r.lighting._z_target = lambda gbuffer: r.lighting.fbo  # no z-buffer: no test
        r.lighting._background.draw = lambda *args, **kwargs: None  # it needs the z-buffer
        r.render()
        every, every_ldr = r.read_hdr(), r.read_ldr()
    finally:
        r.release()
    assert np.array_equal(tested, every)
    assert np.array_equal(tested_ldr, every_ldr)


@pytest.mark.parametrize(("tonemap", "ev"), [("neutral", 0.0), ("aces", 0.7), ("reinhard", -1.3)])
def test_the_fused_display_image_is_the_post_pass_image(gl_egl, tonemap: str, ev: float) -> None:
    """A plain frame's lighting pass writes the display image itself, over a target
    cleared to the background's display value (Renderer.run_lighting, DISPLAY_OUT), and
    no HDR image: until ``read_hdr`` asks, the HDR target keeps what it held. The bytes
    equal the full-screen post pass over the HDR image of the same frame, and that HDR
    image is the unfused frame's, to the bit."""
    from app.bench.scenes import load
    from app.bench.spheres import sphere_grid_scene
    from app.render.renderer import Renderer, RenderOptions

    size = (96, 54)
    data = sphere_grid_scene(2, size)
    data["render"]["tonemap"] = tonemap
    data["camera"]["exposure"] = ev
    data["background"] = [0.3, 0.05, 0.6]
    data["render"]["antialiasing"] = "none"  # the post pass alone, not the FXAA after it
    r = Renderer(gl_egl, load(data), size)
    try:
        assert r.fused_display
        r.lighting.fbo.clear(7.0, 7.0, 7.0, 1.0)  # a stale frame's texels
        r.render()
        fused = r.read_ldr()
        untouched = r.lighting.read()
        hdr = r.read_hdr()  # the HDR lighting pass, run now
        r.post.run(r.hdr_texture, ev)  # every pixel through the post pass
        every = r.read_ldr()
        r.set_options(RenderOptions(fuse_post=False))
        r.render()
        unfused_hdr, unfused = r.read_hdr(), r.read_ldr()
    finally:
        r.release()
    assert np.all(untouched == 7.0)
    differ = np.asarray(every != fused).any(axis=-1)
    assert not differ.any(), f"{differ.sum()} pixels differ"
    assert np.array_equal(hdr, unfused_hdr) and np.array_equal(fused, unfused)
    background = every[0, 0]
    assert background.tolist() != [0, 0, 0] and (every != background).any(axis=-1).mean() > 0.1


def test_frames_draw_the_hdr_image_where_it_is_wanted(gl_egl) -> None:
    """``want_hdr(True)``: every frame draws the HDR image and runs the post pass (one
    lighting pass for a caller that reads both images of every frame); ``want_hdr(False)``
    (the default): a plain frame is fused and draws no HDR image, which ``read_hdr`` then
    draws with the frame's camera. Reading it sets no state: the next frame draws what was
    asked. Same bytes each way, HDR and display."""
    from app.bench.scenes import load
    from app.bench.spheres import sphere_grid_scene
    from app.render.renderer import Renderer

    size = (96, 54)
    r = Renderer(gl_egl, load(sphere_grid_scene(1, size)), size)
    drawn, images, hdrs = [], [], []
    try:
        for wanted in (True, True, False, False):
            r.want_hdr(wanted)
            r.lighting.fbo.clear(7.0, 7.0, 7.0, 1.0)
            r.render()
            drawn.append((r.hdr_drawn, bool((r.lighting.read() != 7.0).any())))
            images.append(r.read_ldr())
            hdrs.append(r.read_hdr())
            assert r.hdr_drawn
    finally:
        r.release()
    assert drawn == [(True, True), (True, True), (False, False), (False, False)]
    assert all(np.array_equal(image, images[0]) for image in images)
    assert all(np.array_equal(hdr, hdrs[0]) for hdr in hdrs)
