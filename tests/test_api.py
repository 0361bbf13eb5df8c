"""The public Python API (app/api.py, docs/api.md): a change between frames keeps the
compiled programs and uploaded meshes and renders, bit for bit, what a renderer built fresh
from the edited scene renders; read-backs have their documented shapes, dtypes and
orientation; bad input is one ``InputError`` and leaves the renderer as it was."""

from __future__ import annotations

import numpy as np
import pytest

from app.api import CHANNELS, OffscreenRenderer, scene_from
from app.errors import InputError
from app.render.renderer import Renderer
from app.resources import scenes_dir

SIZE = (96, 40)

# Built in Python: a horizontal camera over a floor, a sphere in front; the sky fills the
# top half of the image and the floor the bottom (RTR4 §9.4's punctual lights).
HORIZON = {
    "background": [0.1, 0.2, 0.4],
    "camera": {"position": [0.0, 1.0, 6.0], "target": [0.0, 1.0, 0.0], "fov_y": 40.0},
    "materials": {
        "floor": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.8},
        "ball": {"base_color": [0.8, 0.1, 0.1], "roughness": 0.3, "metallic": 1.0},
    },
    "lights": [{"type": "directional", "direction": [-0.3, -1.0, -0.4], "intensity": 2.0}],
    "objects": [
        {"shape": "plane", "size": [200.0, 200.0], "material": "floor"},
        {"shape": "sphere", "radius": 0.5, "position": [1.0, 0.5, 0.0], "material": "ball"},
    ],
}


def fresh(gl, scene, size=SIZE) -> tuple[np.ndarray, np.ndarray]:
    """HDR and LDR of a Renderer built from ``scene`` (a dict or a loaded scene)."""
    r = Renderer(gl, scene_from(scene), size)
    try:
        r.render()
        return r.read_hdr(), r.read_ldr()
    finally:
        r.release()


def assert_same(r: OffscreenRenderer, want: tuple[np.ndarray, np.ndarray]) -> None:
    np.testing.assert_array_equal(r.hdr(), want[0])  # linear HDR, bit for bit
    np.testing.assert_array_equal(r.ldr(), want[1])


@pytest.fixture(scope="module")
def sec4():
    return scene_from("sec4_lights")


def test_a_camera_change_compiles_nothing_and_keeps_the_meshes(gl_egl, sec4):
    """The turntable's step: same programs (the cache object and its size), the same
    vertex buffers, and the fresh renderer's image of the moved camera."""
    with OffscreenRenderer(sec4, SIZE, gl=gl_egl) as r:
        before = r.render()
        cache, programs = r.renderer.shaders, len(r.renderer.shaders)
        buffers = [d.vbo for d in r.renderer.gbuffer_pass.drawables]
        r.set_camera(position=[1.5, 3.0, 6.0], fov_y=50.0)
        after = r.render()
        assert r.renderer.shaders is cache and len(cache) == programs
        assert [d.vbo for d in r.renderer.gbuffer_pass.drawables] == buffers
        assert not np.array_equal(before, after)  # the camera did move
        data = sec4.scene.model_dump(exclude_none=True)
        data["camera"].update(position=[1.5, 3.0, 6.0], fov_y=50.0)
        assert_same(r, fresh(gl_egl, scene_from(data, sec4.path.parent)))


def test_each_change_renders_what_a_fresh_renderer_renders(gl_egl):
    """Material, lights, settings and size changed one after another on one renderer, each
    frame equal to a renderer built from the scene edited so far."""
    data = {k: (v.copy() if isinstance(v, dict) else v) for k, v in HORIZON.items()}
    data["materials"] = {k: dict(v) for k, v in HORIZON["materials"].items()}
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        r.render()
        r.set_material("ball", roughness=0.6, ndf="beckmann")
        data["materials"]["ball"].update(roughness=0.6, ndf="beckmann")
        r.render()
        assert_same(r, fresh(gl_egl, data))
        lights = [{"type": "point", "position": [0.0, 2.0, 2.0], "intensity": 5.0, "range": 9.0}]
        r.set_lights(lights)
        data["lights"] = lights
        r.render()
        assert_same(r, fresh(gl_egl, data))
        r.set_settings(tonemap="aces", terms="specular")
        data["render"] = {"tonemap": "aces", "terms": "specular"}
        r.render()
        assert_same(r, fresh(gl_egl, data))
        r.resize((64, 48))
        assert r.render().shape == (48, 64, 3)
        assert_same(r, fresh(gl_egl, data, (64, 48)))


def test_read_backs_shapes_dtypes_and_orientation(gl_egl):
    """Row 0 is the top: the sky (nothing drawn, the background's radiance) fills the top
    rows, the floor (normal +y, depth growing towards the horizon) the bottom rows."""
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        ldr = r.render()
        hdr, depth = r.hdr(), r.depth()
        ch = r.channels()
    w, h = SIZE
    assert ldr.shape == (h, w, 3) and ldr.dtype == np.uint8
    assert hdr.shape == (h, w, 3) and hdr.dtype == np.float32
    assert depth.shape == (h, w) and depth.dtype == np.float32
    assert set(ch) == set(CHANNELS)
    assert ch["normal"].shape == (h, w, 3) and ch["material_id"].dtype == np.int32
    assert not ch["covered"][0].any() and ch["covered"][-1].all()
    np.testing.assert_array_equal(depth[0], 0.0)
    np.testing.assert_allclose(hdr[0], np.broadcast_to([0.1, 0.2, 0.4], (w, 3)), rtol=1e-6)
    assert np.all(depth[-1] > 0.0) and depth[-1].mean() < depth[h // 2 + 2].mean()
    np.testing.assert_allclose(ch["normal"][-1], np.broadcast_to([0, 1, 0], (w, 3)), atol=1e-6)
    np.testing.assert_array_equal(ch["normal"][0], 0.0)
    assert np.all(ch["material_id"][0] == -1)
    # The metallic ball (right of centre, below the horizon) is where metallic = 1.
    ys, xs = np.nonzero(ch["metallic"] > 0.5)
    assert xs.size and xs.mean() > w / 2 and ys.mean() > h / 2


def test_supersampled_gbuffer_is_at_render_size(gl_egl):
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        r.set_settings(supersample=2)
        assert r.render().shape == (SIZE[1], SIZE[0], 3)
        assert r.render_size == (2 * SIZE[0], 2 * SIZE[1])
        assert r.depth().shape == (2 * SIZE[1], 2 * SIZE[0])


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda r: r.set_camera(fov_y=500.0), "camera.fov_y: Input should be less than 180"),
        (lambda r: r.set_camera(colour=1), "camera.colour: unknown key"),
        (lambda r: r.set_material("ball", roughness=2.0), "materials.ball.roughness:"),
        (lambda r: r.set_material("nope", roughness=0.2), "materials.nope: unknown material"),
        (lambda r: r.set_lights([{"type": "laser"}]), "lights[0].type:"),
        (lambda r: r.set_settings(tonemap="magic"), "render.tonemap:"),
        (lambda r: r.resize((0, 10)), "size.width:"),
        (lambda r: r.channel("albedo"), "unknown channel 'albedo'"),
    ],
)
def test_bad_input_is_one_line_and_changes_nothing(gl_egl, change, message):
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        before = r.render()
        scene = r.scene
        with pytest.raises(InputError) as info:
            change(r)
        text = str(info.value)
        assert message in text and "\n" not in text
        assert r.scene == scene
        np.testing.assert_array_equal(r.render(), before)


def test_a_bad_dict_names_the_python_scene_and_the_key():
    bad = {**HORIZON, "objects": [{"shape": "sphere", "material": "gold"}]}
    with pytest.raises(InputError, match=r"<python scene>: objects\[0\]\.material: unknown"):
        OffscreenRenderer(bad, SIZE)


def test_reads_need_a_frame_of_the_current_scene_and_close_releases(gl_egl):
    r = OffscreenRenderer(HORIZON, SIZE, gl=gl_egl)
    with pytest.raises(RuntimeError, match="render"):
        r.hdr()
    r.render()
    r.set_camera(position=[0.0, 2.0, 6.0])
    with pytest.raises(RuntimeError, match="render"):
        r.depth()  # the frame on the GPU is of the old camera
    r.close()
    r.close()
    with pytest.raises(RuntimeError, match="closed"):
        r.render()
    assert not gl_egl.ctx.error or gl_egl.ctx.error == "GL_NO_ERROR"  # a shared context lives


@pytest.mark.gl
def test_own_context_is_released_on_exit():
    with OffscreenRenderer(scenes_dir() / "sec3_lambert.toml", (32, 16), backend="egl") as r:
        assert r.render().shape == (16, 32, 3)
        gl = r.gl
    assert r.renderer is None
    with pytest.raises(Exception):  # noqa: B017 - moderngl's error for a released context
        gl.ctx.texture((1, 1), 4)


def test_emission_and_occlusion_channels(gl_egl):
    """RT5 through the API: a material's emitted radiance where it is drawn, the occlusion
    map's factor (1 + strength (o - 1)) on the floor; 0 and 1 where nothing was drawn and
    in a frame without RT5."""
    scene = {
        "camera": {"position": [0, 1.5, 4], "target": [0, 0.5, 0]},
        "environment": {"radiance": [0.5, 0.5, 0.5]},
        "materials": {
            "glow": {"emissive": [2.0, 1.0, 0.5], "emissive_strength": 3.0},
            "floor": {"occlusion_map": "textures/noise.png", "occlusion_strength": 0.5},
        },
        "objects": [
            {"shape": "sphere", "radius": 0.5, "position": [0, 0.5, 0], "material": "glow"},
            {"shape": "plane", "size": [6, 6], "material": "floor"},
        ],
    }
    with OffscreenRenderer(scene, SIZE, base_dir="scenes", gl=gl_egl) as r:
        r.render()
        ch = r.channels(("emission", "occlusion", "covered"))
    # Both materials share one row of the material table (emission and occlusion are
    # per pixel, not table parameters): the ball is found by its emission.
    ball = np.any(ch["emission"] > 0.0, axis=-1)
    floor = ch["covered"] & ~ball
    assert 20 < ball.sum() < floor.sum()
    np.testing.assert_allclose(
        ch["emission"][ball], np.broadcast_to([6.0, 3.0, 1.5], (ball.sum(), 3))
    )
    np.testing.assert_array_equal(ch["emission"][~ball], 0.0)
    occ = ch["occlusion"]
    assert occ[floor].min() >= 0.5 - 1e-6 and occ[floor].max() <= 1.0
    assert occ[floor].std() > 0.01  # the noise map varies it
    np.testing.assert_array_equal(occ[~ch["covered"]], 1.0)
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        r.render()
        plain = r.channels(("emission", "occlusion"))
    np.testing.assert_array_equal(plain["emission"], 0.0)
    np.testing.assert_array_equal(plain["occlusion"], 1.0)


def test_want_hdr_draws_both_images_with_the_frame(gl_egl):
    """``want_hdr``: each frame draws the HDR image itself (the renderer's ``hdr_drawn``
    before any read), and both images are the bytes of a frame that fuses post into the
    lighting pass and draws the HDR image on demand."""
    want = fresh(gl_egl, HORIZON)
    with OffscreenRenderer(HORIZON, SIZE, gl=gl_egl) as r:
        r.render()
        assert not r._live().hdr_drawn  # a plain frame: the display image only
        r.want_hdr()
        for _ in range(2):
            r.render()
            assert r._live().hdr_drawn
            assert_same(r, want)
