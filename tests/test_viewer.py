"""The desktop viewer in a real glfw window on a private Xvfb server: what the window shows is
what the headless renderer renders for the same scene state (one code path), real mouse
input moves the camera, edits save and reload to the same image, bad edits (a value, a
scene file, a GLSL file) leave the last good state running with the error on screen, and
hundreds of frames leak no GL object. The window fits each scene's framing to its image area
(the sensor fit, ``fit_scene``), so the headless render it equals is ``pbs render --fit``'s
at the area's size."""

from __future__ import annotations

import shutil
import subprocess
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from app.frame.camera import fit_scene
from app.render.renderer import Renderer, RenderOptions
from app.resources import glsl_dir, scenes_dir
from app.scene.edits import get_key
from app.scene.loader import load_scene
from tests.test_stability_renderer import GLCensus, resident_mib

SIZE = (320, 180)


@pytest.fixture
def scene_copy(tmp_path: Path) -> Path:
    """sec4_lights.toml (every light type) copied where a test may edit and save it."""
    path = tmp_path / "lights.toml"
    shutil.copy(scenes_dir() / "sec4_lights.toml", path)
    return path


@pytest.fixture
def viewer(xdisplay: str, scene_copy: Path):
    from app.viewer.window import Viewer

    v = Viewer(scene_copy, SIZE, vsync=False)
    v.settle()
    yield v
    v.close()


# the viewer's frames: without a still's interior correction (app/viewer/window.py)
VIEWER_FRAMES = RenderOptions(interactive=True)


def headless(gl, loaded, size) -> np.ndarray:
    """``pbs render``'s image of the same state as the viewer draws it (its frames leave
    out a still's interior correction, ``RenderOptions.interactive``), in its own
    headless (EGL) context."""
    with gl.ctx:  # current for these calls; the viewer makes its own current again
        r = Renderer(gl, loaded, size, options=VIEWER_FRAMES)
        try:
            r.render()
            return r.read_ldr()
        finally:
            r.release()


def window_image(v) -> np.ndarray:
    """The window without the panels, after every edit has landed at full size."""
    shown = v.show_ui
    v.show_ui = False
    v.settle()
    image = v.read_window()
    v.show_ui = shown
    return image


def assert_close(got: np.ndarray, want: np.ndarray) -> None:
    assert got.shape == want.shape
    diff = np.abs(got.astype(np.int16) - want.astype(np.int16))
    assert diff.max() <= 1, f"max difference {diff.max()}/255"


def test_window_equals_the_headless_render_after_scripted_edits(viewer, gl_egl):
    """Camera moves, a material, a light and a setting edited through the viewer's API:
    the window's framebuffer equals ``pbs render``'s renderer on the same scene state,
    within 1/255 per channel."""
    v = viewer
    before = window_image(v)
    v.orbit(40, -15)
    v.zoom(1.5)
    v.pan(10, 5)
    assert v.edit({"materials.ball.roughness": 0.15, "materials.ball.metallic": 1.0})
    assert v.edit({"lights[0].intensity": 0.6})
    assert v.edit({"materials.floor.ndf": "beckmann", "render.tonemap": "aces"})
    after = window_image(v)
    assert not np.array_equal(before, after)  # the edits show
    size = v.framebuffer_size  # sec4_lights is 2.4:1, the 16:9 window shows it fitted
    assert_close(after, headless(gl_egl, fit_scene(v.document.loaded, size), size))


def test_a_structural_edit_shows_the_notice_before_it_compiles(viewer):
    """A new model combination is applied one frame late, behind "compiling..."."""
    v = viewer
    assert v.edit({"materials.ball.diffuse": "burley"})
    assert v.state.pending and v.state.notice == "compiling..."
    v.step()  # the notice frame: the edit is not applied yet
    assert v.value("materials.ball.diffuse") is None
    v.step()
    assert v.value("materials.ball.diffuse") == "burley" and not v.state.pending


def test_real_mouse_drag_orbits_the_camera(viewer):
    """xdotool drags the left mouse button across the window on the X server; the glfw
    callbacks turn it into an orbit (the camera moves, the target stays)."""
    v = viewer
    if shutil.which("xdotool") is None:
        pytest.fail("xdotool is missing: run `bash scripts/dev.sh setup` (it installs it)")
    import glfw

    v.show_ui = False  # a press on a panel belongs to the panel, not to the camera
    for _ in range(5):
        v.step()
    start = v.scene.camera
    window = str(glfw.get_x11_window(v.window))  # coordinates relative to the window itself
    drag = subprocess.Popen(
        ["xdotool", "mousemove", "--window", window, "100", "90", "mousedown", "1",
         "sleep", "0.1", "mousemove", "--window", window, "160", "100", "sleep", "0.1",
         "mousemove", "--window", window, "220", "110", "sleep", "0.1", "mouseup", "1"],
    )  # fmt: skip
    deadline = time.monotonic() + 10.0
    while drag.poll() is None and time.monotonic() < deadline:
        v.step()
    for _ in range(5):
        v.step()
    assert drag.returncode == 0
    moved = v.scene.camera
    assert moved.target == start.target
    assert np.linalg.norm(np.subtract(moved.position, start.position)) > 0.5


def test_click_selects_the_object_and_material_under_the_cursor(viewer):
    """A click maps into the image area (left of the docked panels); a click on the panels'
    column selects nothing."""
    v = viewer
    # The left ball (objects[1]) projected into the image area by the drawn frame's camera.
    ix, iy, w, h = v.image_rect
    assert w < v.framebuffer_size[0]  # the panels' column is beside the image
    centre = np.array([*v.scene.objects[1].position, 1.0])
    clip = v.renderer.proj @ v.renderer.view @ centre
    x = ix + (clip[0] / clip[3] * 0.5 + 0.5) * w
    y = iy + (0.5 - clip[1] / clip[3] * 0.5) * h
    chosen = v.select_pixel(x, y)
    assert (chosen.object_index, chosen.material) == (1, "ball")
    floor = v.select_pixel(ix + w / 2, iy + h - 2)
    assert (floor.object_index, floor.material) == (0, "floor")
    assert v.select_pixel(ix + w + 4, iy + h - 2).object_index is None  # on the panels


def test_edit_save_load_renders_the_same(viewer, gl_egl, tmp_path):
    """The saved file loads and renders bit-identically to what the window shows, and the
    scene's comments survive the save."""
    v = viewer
    v.orbit(-30, 10)
    assert v.edit(
        {"materials.ball.fresnel": "schlick_generalized", "materials.ball.f90": [1.0, 0.5, 0.2]}
    )
    assert v.edit({"lights[1].color": [0.2, 1.0, 0.4]})
    shown = window_image(v)
    out = tmp_path / "saved" / "edited.toml"
    v.save_scene(out)
    text = out.read_text(encoding="utf-8")
    assert text.startswith("# RTR4 §9.4")  # the file's opening comment kept
    loaded = load_scene(out)
    assert loaded.scene == v.scene
    size = v.framebuffer_size
    assert np.array_equal(headless(gl_egl, fit_scene(loaded, size), size), shown)


def test_a_refused_value_changes_nothing_and_says_what_the_cli_says(viewer):
    v = viewer
    before = window_image(v)
    assert not v.edit({"materials.ball.roughness": 1.5})
    assert "materials.ball.roughness" in v.state.error
    assert "less than or equal to 1" in v.state.error
    assert v.value("materials.ball.roughness") == 0.35
    assert np.array_equal(window_image(v), before)


def test_a_broken_scene_file_keeps_the_last_good_state(viewer, scene_copy):
    """Hot reload: a scene file edited into something invalid is reported (file and key)
    and the window keeps rendering the last good scene; fixing it reloads it."""
    v = viewer
    before = window_image(v)
    good = scene_copy.read_text(encoding="utf-8")
    scene_copy.write_text(good.replace("roughness = 0.35", "roughness = -2.0"), encoding="utf-8")
    _wait_for(v, lambda: bool(v.state.error))
    assert str(scene_copy) in v.state.error and "materials.ball.roughness" in v.state.error
    assert np.array_equal(window_image(v), before)
    scene_copy.write_text(good.replace("roughness = 0.35", "roughness = 0.9"), encoding="utf-8")
    _wait_for(v, lambda: not v.state.error)
    assert v.scene.materials["ball"].roughness == 0.9
    assert not np.array_equal(window_image(v), before)


def test_a_broken_glsl_file_keeps_running_and_names_file_and_line(viewer, tmp_path, monkeypatch):
    """Hot reload of glsl/ (a copy): a compile error is shown with its file and line, the
    last good image stays; the fixed file compiles again."""
    import app.gl.shaders as shaders
    import app.viewer.window as window

    copy = tmp_path / "glsl"
    shutil.copytree(glsl_dir(), copy)
    monkeypatch.setattr(shaders, "glsl_dir", lambda: copy)
    monkeypatch.setattr(window, "glsl_dir", lambda: copy)
    v = viewer
    before = window_image(v)
    ndf = copy / "brdf" / "ndf.glsl"
    good = ndf.read_text(encoding="utf-8")
    lines = good.split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith("float D_GGX("))
    lines.insert(at + 1, "    float broken = no_such_variable;")
    ndf.write_text("\n".join(lines), encoding="utf-8")
    _wait_for(v, lambda: bool(v.state.error))
    assert f"glsl/brdf/ndf.glsl:{at + 2}:" in v.state.error, v.state.error
    assert "no_such_variable" in v.state.error
    assert np.array_equal(window_image(v), before)
    ndf.write_text(good, encoding="utf-8")
    _wait_for(v, lambda: not v.state.error)
    assert np.array_equal(window_image(v), before)


def _wait_for(v, condition, seconds: float = 10.0) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        v.step()
        time.sleep(0.02)


def test_500_frames_of_interaction_leak_nothing(xdisplay: str, scene_copy: Path):
    """Orbits, zooms, material, light and setting edits, lights added and removed: after one
    40-frame cycle of them (every program compiled, every allocation made) come 520 more
    frames, 13 whole cycles; the GL objects alive at the end are those alive before, and
    the process's resident size, sampled at the end of each cycle, has a floor that rises
    by less than 10 MB from the first four cycles to the last four.

    The viewer runs in a process of its own, as ``pbs view`` does: a test worker's
    resident size carries the heap of every module it ran before. And the resident size
    jumps by about 30 MiB now and then and falls back (a full run's child read -5 MiB for
    twelve cycles and +29 at the thirteenth; the driver's and malloc's transient memory),
    so a single before/after difference failed without a leak; a leak raises the floor.
    A leak of 100 kB a frame, injected, raised it by 23 MiB."""
    import json
    import os
    import sys

    code = "import sys; from tests.test_viewer import _leak_run; _leak_run(sys.argv[1])"
    proc = subprocess.run(
        [sys.executable, "-c", code, str(scene_copy)],
        capture_output=True, text=True, timeout=600,
        env={**os.environ, "DISPLAY": xdisplay}, cwd=Path(__file__).parent.parent,
    )  # fmt: skip
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    assert proc.returncode == 0 and lines, proc.stderr[-2000:]
    out = json.loads(lines[-1])
    assert out["after"] == out["before"], (out["before"], out["after"])
    trace = out["trace"]
    growth = min(trace[-4:]) - min(trace[:4])
    assert growth < 10.0, f"RSS floor rose {growth:.1f} MiB; per cycle {trace}"


def _leak_run(scene: str) -> None:
    """The child of the test above: the viewer on ``scene``, 14 cycles of ``_interact``;
    prints the GL census before and after and the resident size at the end of each
    cycle (MiB, relative to the start) as one JSON line."""
    import json

    from app.viewer.window import Viewer

    v = Viewer(Path(scene), SIZE, vsync=False)
    try:
        v.settle()
        census = GLCensus(v.gl)
        for frame in range(CYCLE):
            _interact(v, frame)
        v.settle()
        before = census.live()
        rss = resident_mib()
        trace = []
        for frame in range(CYCLE, 14 * CYCLE):
            _interact(v, frame)
            if frame % CYCLE == CYCLE - 1:
                trace.append(round(resident_mib() - rss, 1))
        v.settle()
        after = census.live()
    finally:
        v.close()
    print(json.dumps({"before": before, "after": after, "trace": trace}))


CYCLE = 40  # frames after which _interact has come back to the same scene


def _interact(v, frame: int) -> None:
    kind = frame % 10
    if kind < 4:
        v.orbit(7.0, 1.0 if frame % 20 < 10 else -1.0)
    elif kind == 4:
        v.zoom(0.3 if frame % 40 < 20 else -0.3)
    elif kind == 5:
        v.edit({"materials.ball.roughness": 0.2 + 0.05 * (frame % 7)})
    elif kind == 6:
        v.edit({"lights[0].intensity": 0.1 + 0.01 * (frame % 9)})
    elif kind == 7:
        v.edit({"materials.floor.ndf": "beckmann" if frame % 20 < 10 else "ggx"})
    elif kind == 8:
        if frame % 40 < 20:
            v.add_light("point")
        elif len(v.scene.lights) > 8:
            v.remove_light(len(v.scene.lights) - 1)
    else:
        v.edit({"render.tonemap": "aces" if frame % 20 < 10 else "neutral"})
    v.step()


def test_comparison_in_the_window_equals_the_headless_comparison(viewer):
    """A split (divider moved) and a difference view in the window: each equals
    ``Comparison``'s composite of the same state rendered headless; orbiting keeps both
    sides in step."""
    from app.gl.context import create_context
    from app.render.compare import CompareSpec, Comparison

    v = viewer
    assert v.compare("materials.ball.roughness", 0.1, 0.8)
    v.set_divider(0.3)
    v.orbit(25, 0)
    split = window_image(v)
    v.compare_mode = "difference"
    v.state.dirty = True
    difference = window_image(v)
    gl = create_context("egl")
    try:
        with gl.ctx:
            spec = CompareSpec("materials.ball.roughness", 0.1, 0.8)
            size = v.framebuffer_size
            c = Comparison(gl, fit_scene(v.document.loaded, size), spec, size, VIEWER_FRAMES)
            try:
                c.render()
                c.composite("split", 0.3)
                want_split = c.read_ldr()
                c.composite("difference", gain=8.0)
                want_difference = c.read_ldr()
            finally:
                c.release()
    finally:
        gl.release()
    assert_close(split, want_split)
    assert_close(difference, want_difference)
    assert difference.max() > 0 and not np.array_equal(split, difference)
    assert not v.compare("materials.ball.roughness", 0.1, 7.0)  # refused, reported
    assert "roughness" in v.state.error and v.comparison is not None
    v.stop_compare()
    assert v.comparison is None


@pytest.mark.parametrize(("view", "light"), [("ndf", 3), ("normal", 0), ("tiles", 0)])
def test_debug_views_in_the_window_equal_the_headless_ones(viewer, view, light):
    """``--debug VIEW`` in the window equals DebugPass on a headless renderer of the same
    state (what ``pbs render --debug`` writes)."""
    from app.gl.context import create_context
    from app.render.debug_views import DebugPass

    v = viewer
    v.orbit(-20, 5)
    assert v.set_debug_view(view, light)
    shown = window_image(v)
    gl = create_context("egl")
    try:
        with gl.ctx:
            size = v.framebuffer_size
            r = Renderer(gl, fit_scene(v.document.loaded, size), size)
            debug = DebugPass(r)
            try:
                r.render()
                debug.run(view, light)
                want = debug.read_display()
            finally:
                debug.release()
                r.release()
    finally:
        gl.release()
    assert_close(shown, want)
    assert not v.set_debug_view("ndf", 99) and "light" in v.state.error
    assert v.set_debug_view(None)
    assert not np.array_equal(window_image(v), shown)


def test_a_dropped_mesh_opens_framed_and_a_bad_file_is_reported(viewer, tmp_path):
    """Opening a mesh file (what a drop does) shows it in a scene of its own, framed;
    saving that scene writes a file that renders the same; a file that is no mesh is
    reported and the current scene stays."""
    v = viewer
    mesh = tmp_path / "teapot.obj"
    shutil.copy(scenes_dir() / "meshes" / "teapot.obj", mesh)
    assert v.open_scene(mesh)
    assert v.scene.objects[0].shape == "mesh"
    image = window_image(v)
    covered = (np.abs(image.astype(int) - image[0, 0].astype(int)).sum(axis=-1) > 0).mean()
    assert 0.05 < covered < 0.95  # the teapot fills a good part of the view
    saved = v.save_scene(tmp_path / "teapot-view.toml")
    assert load_scene(saved).scene == v.scene
    junk = tmp_path / "junk.obj"
    junk.write_text("this is not a mesh\n", encoding="utf-8")
    assert not v.open_scene(junk)
    assert "junk.obj" in v.state.error
    assert v.scene.objects[0].file == "teapot.obj"


@pytest.mark.parametrize(
    "scene",
    [
        "sec10_cloth.toml", "sec10_cloth_empirical.toml", "sec10_cloth_fibers.toml",
        "sec11_thin_film.toml", "sec11_diffraction.toml", "sec12_layered_variants.toml",
        "transmission.toml",
    ],
)  # fmt: skip
def test_the_layered_controls_draw_and_their_toggles_are_valid_edits(viewer, tmp_path, scene):
    """The Material panel draws every section open for each material of the scenes of
    RTR4 §9.10-9.12 (sheen, empirical cloth, fibres, thin film, grating, both coat
    models) without an error, and the edits its toggles make are taken: leaving the
    empirical cloth model or a fibre model removes their keys, a grating turns on and
    off, the coat model switches."""
    from app.viewer.panels import diffuse_edit, fiber_edit, grating_edit

    v = viewer
    path = tmp_path / scene
    shutil.copy(scenes_dir() / scene, path)
    assert v.open_scene(path)
    v.panels.open_sections = True
    for name in v.scene.materials:
        v.selection.material = name
        v.step(2)
        assert not v.state.error, (name, v.state.error)
    if scene == "sec10_cloth_fibers.toml":
        name = next(n for n, m in v.scene.materials.items() if m.fiber_kd is not None)
        key = f"materials.{name}"
        assert not v.edit({f"{key}.fiber": "kajiya_kay"})  # Sadeghi's keys would stay
        assert v.edit(fiber_edit(key, "sadeghi", "kajiya_kay"))
        v.settle()
        assert v.scene.materials[name].fiber == "kajiya_kay"
        assert v.edit(fiber_edit(key, "kajiya_kay", "none"))
        v.settle()
        assert v.scene.materials[name].fiber_rotation is None
    elif scene == "sec10_cloth_empirical.toml":
        name = next(n for n, m in v.scene.materials.items() if m.cloth_wrap is not None)
        key = f"materials.{name}"
        assert not v.edit({f"{key}.diffuse": "burley"})  # the cloth keys would be left behind
        assert v.edit(diffuse_edit(key, "cloth_empirical", "burley"))
        v.settle()
        assert v.scene.materials[name].diffuse == "burley"
        assert v.scene.materials[name].cloth_wrap is None
    if scene == "sec11_diffraction.toml":
        name = next(n for n, m in v.scene.materials.items() if m.grating_period is not None)
        assert v.edit(grating_edit(f"materials.{name}", False))
        v.settle()
        assert v.scene.materials[name].diffraction == "none"
        assert v.edit(grating_edit(f"materials.{name}", True))
        v.settle()
        assert v.scene.materials[name].diffraction == "grating"
    if scene.startswith("sec12"):
        name = next(n for n, m in v.scene.materials.items() if m.clearcoat > 0)
        assert v.edit({f"materials.{name}.clearcoat_model": "weidlich_wilkie"})
        v.settle()
        assert v.scene.materials[name].clearcoat_model == "weidlich_wilkie"
        assert not v.state.error


# --- the classroom walkthrough in the viewer (app/viewer/lesson.py) ---------------------------


@pytest.fixture(scope="module")
def lesson_steps():
    """The bundled walkthrough's 13 steps, validated once for the module (about 5 s)."""
    from app.resources import walkthrough_dir
    from app.walkthrough.model import load_walkthrough

    return load_walkthrough(walkthrough_dir())


def ink(image: np.ndarray) -> np.ndarray:
    """Pixels that differ from the crop's most common colour (its background)."""
    flat = image.reshape(-1, 3)
    values, counts = np.unique(flat, axis=0, return_counts=True)
    return np.abs(image.astype(int) - values[counts.argmax()].astype(int)).sum(axis=-1) > 60


def crop(image: np.ndarray, rect: tuple[float, float, float, float]) -> np.ndarray:
    x0, y0, x1, y1 = (round(c) for c in rect)
    return image[y0:y1, x0:x1]


def test_pbs_view_walkthrough_opens_step_1(xdisplay, monkeypatch):
    """``pbs view --walkthrough`` opens the viewer on step 1's first scene with the panel;
    ``--step 14`` is one line and exit 2 before any window opens."""
    from app import cli
    from app.viewer.window import Viewer

    seen = {}

    def run(self):  # instead of the interactive loop: a frame, then what it shows
        self.settle()
        seen["lesson"] = (self.lesson.index, self.lesson.current.step.section, self.lesson.lang)
        seen["scene"] = self.document.path.name
        seen["error"] = self.state.error

    monkeypatch.setattr(Viewer, "run", run)
    assert cli.main(["view", "--walkthrough", "--size", "320x180", "--no-vsync"]) == 0
    assert seen == {"lesson": (0, 1, "en"), "scene": "sec1_specular.toml", "error": ""}
    assert cli.main(["view", "--walkthrough", "--step", "14"]) == 2
    assert "lesson" in seen  # (the second call opened nothing: `run` was not reached again)


def test_walkthrough_next_and_previous_through_all_steps(viewer, lesson_steps):
    """Next through all 13 steps and previous back to the first: every step's panel draws
    (text, inline math and equations as textures) with no error, each step's equations
    are textures with ink, and the formula textures are released at each step change
    and at the end no GL object is left over from the walk."""
    v = viewer
    assert v.open_walkthrough(lesson_steps, "en", 1)
    v.step(2)
    census = GLCensus(v.gl)
    before = census.live()
    sections = []
    for direction in [v.lesson.next] * 12 + [v.lesson.previous] * 12:
        sections.append(v.lesson.current.step.section)
        assert len(v.lesson.math) > 0  # the step's text and equations were drawn
        for image in v.lesson.math.images():
            assert np.frombuffer(image.texture.read(), np.uint8)[3::4].max() > 128
        assert direction()
        assert len(v.lesson.math) == 0  # released with the step
        v.step(2)
        assert not v.state.error, (v.lesson.current.slug, v.state.error)
    assert sections == [*range(1, 13), *range(13, 1, -1)]
    assert v.lesson.index == 0
    assert census.live() == before


def test_a_comparison_draws_its_sides_as_the_main_view_does(viewer):
    """A comparison's sides are the viewer's frames, as its main view is (its
    ``RenderOptions``): with ``render.gbaa_interior``, a still's correction the viewer's
    frames leave out, the scene split against itself shows what it shows alone, but for
    the divider line."""
    from app.render.compare import divider_line

    v = viewer
    assert v.edit({"render.antialiasing": "gbaa", "render.gbaa_interior": True})
    alone = window_image(v)
    assert v.compare("render.gbaa_interior", True, True)
    assert all(r.options == v.renderer.options for r in v.comparison.renderers)
    split = window_image(v)
    line = list(divider_line(v.divider, split.shape[1]))
    split[:, line] = alone[:, line]
    assert_close(split, alone)


def test_walkthrough_comparison_equals_the_headless_compare(viewer, lesson_steps):
    """Step 5's first comparison (gold: Schlick | exact conductor Fresnel) in one call, as
    its button does: the window shows the split screen that ``pbs render --compare --fit``
    makes of the same scene file, key and values (a step keeps the scene's framing), drawn
    as the viewer's frames are."""
    from app.gl.context import create_context
    from app.render.compare import CompareSpec, Comparison

    v = viewer
    assert v.open_walkthrough(lesson_steps, "en", 5)
    c = v.lesson.current.step.comparisons[0]
    assert v.lesson.compare(0) and v.comparison is not None
    fitted = v.framebuffer_size  # the fit is to the image area: the window, panels hidden
    shown = window_image(v)
    gl = create_context("egl")
    try:
        with gl.ctx:
            loaded = fit_scene(load_scene(scenes_dir() / f"{c.scene}.toml"), fitted)
            comp = Comparison(
                gl, loaded, CompareSpec(c.key, c.a, c.b), v.framebuffer_size, VIEWER_FRAMES
            )
            try:
                comp.render()
                comp.composite("split", v.divider)  # the window's, on the gold spheres
                want = comp.read_ldr()
            finally:
                comp.release()
    finally:
        gl.release()
    assert_close(shown, want)
    assert v.document.path.name == f"{c.scene}.toml"


def test_split_on_difference_centres_the_object_the_sides_differ_on() -> None:
    """The divider goes to the median column of the sides' difference (the middle of
    the object they differ on, a small faint one aside), or, where that falls between
    two objects, onto the nearer one; 0.5 where the sides are the same."""
    from app.viewer.window import split_on_difference

    a = np.zeros((90, 400, 3), np.uint8)
    b = a.copy()
    assert split_on_difference(a, b) == 0.5
    b[30:60, 300:340] = 200  # an object at columns 300..339
    b[40:50, 40:50] = 30  # a small, faint one
    assert abs(split_on_difference(a, b) * 400 - 320) <= 2
    b[30:60, 100:140] = 200  # another like it: the median between them, on neither
    assert (
        100 <= split_on_difference(a, b) * 400 < 140 or 300 <= split_on_difference(a, b) * 400 < 340
    )


@pytest.mark.parametrize("size", [(960, 540), (1600, 900)])
def test_walkthrough_split_falls_on_the_compared_object(xdisplay, lesson_steps, size):
    """With the panels docked, a step's comparison opens with its divider on the object
    the two sides differ on: step 5's copper in air | in water (a column left of the
    image area's middle, which the divider at the middle missed, the copper wholly on the
    A side) and step 4's spot cone (a pool right of the middle). The sides differ in the
    columns just left and just right of the divider."""
    from app.viewer.window import Viewer

    v = Viewer(None, size, vsync=False)
    try:
        assert v.open_walkthrough(lesson_steps, "en", 5)
        for section, i in ((5, 2), (4, 0)):
            assert v.lesson.go_section(section) and v.lesson.compare(i)
            v.settle()
            a, b = (side.read_ldr().astype(np.int16) for side in v.comparison.renderers)
            differ = np.abs(a - b).max(axis=(0, 2)) > 8  # per column of the image area
            x, near = int(v.divider * a.shape[1]), max(a.shape[1] // 50, 2)
            assert differ[x - near : x].any() and differ[x + 1 : x + 1 + near].any(), (
                f"step {section}: the divider at {x} of {a.shape[1]} misses the columns "
                f"the sides differ in: {np.flatnonzero(differ)}"
            )
    finally:
        v.close()


def test_walkthrough_sweep_value_and_reset(viewer, lesson_steps, gl_egl):
    """Step 8's roughness sweep at 0.35 (what its slider sets) shows what the headless
    renderer shows of the scene file with every swept key at 0.35; "play" moves the value
    between the ends; "reset this step" drops the edit (the scene is its file again)."""
    from app.walkthrough.model import with_values

    v = viewer
    assert v.open_walkthrough(lesson_steps, "en", 8)
    lesson = v.lesson
    i = next(k for k, s in enumerate(lesson.current.step.sweeps) if s.keys[0].endswith("roughness"))
    sweep = lesson.current.step.sweeps[i]
    assert lesson.select_sweep(i)
    assert lesson.set_sweep(0.35)
    fitted = v.framebuffer_size  # the fit is to the image area: the window, panels hidden
    shown = window_image(v)
    loaded = fit_scene(lesson.current.scene(sweep.scene), fitted)
    want = with_values(loaded, sweep.keys, 0.35, lesson.current.path, "sweeps[0]", "sweeps[0]")
    assert_close(shown, headless(gl_egl, want, v.framebuffer_size))
    assert all(v.value(key) == 0.35 for key in sweep.keys)
    lesson.play(True)
    values = set()
    for _ in range(6):
        v.step()
        time.sleep(0.05)
        values.add(round(lesson.sweep_value, 4))
    assert len(values) > 2 and all(min(sweep.start, sweep.to) <= x <= max(sweep.start, sweep.to)
                                   for x in values)  # fmt: skip
    assert lesson.reset()
    assert not lesson.playing and lesson.sweep is None
    on_file = tomllib.loads((scenes_dir() / f"{sweep.scene}.toml").read_text(encoding="utf-8"))
    assert all(v.value(key) == get_key(on_file, key) != 0.35 for key in sweep.keys)
    assert_close(window_image(v), headless(gl_egl, loaded, v.framebuffer_size))


def test_walkthrough_equations_and_korean_draw_in_the_window(xdisplay, scene_copy, lesson_steps):
    """In a 960x1000 window, Korean step 13: each equation the panel shows whole is a
    formula texture with ink where the panel drew it; the title, drawn with the Hangul
    font merged into ImGui's default one, has ink and differs from the same title drawn
    with a second copy of the default font alone (each Hangul syllable its missing-glyph
    box)."""
    from imgui_bundle import imgui

    from app.viewer.window import Viewer

    v = Viewer(scene_copy, (960, 1000), vsync=False)
    try:
        assert v.open_walkthrough(lesson_steps, "ko", 13)
        assert v.lesson.lang == "ko" and v.panels.hangul
        v.settle()
        v.step(2)
        panel = v.panels.lesson_panel
        image = v.read_window()
        _, y0, _, y1 = panel.window_rect
        inside = [r for r in panel.equation_rects if r[1] >= y0 and r[3] <= y1]
        assert inside and len(v.lesson.math) >= len(panel.equation_rects)
        for rect in inside:
            assert ink(crop(image, rect)).mean() > 0.02, rect
        korean = crop(image, panel.title_rect)
        panel.title_font = imgui.get_io().fonts.add_font_default()  # no Hangul in it
        v.step(3)
        boxes = crop(v.read_window(), panel.title_rect)
        panel.title_font = None
        assert ink(korean).mean() > 0.05
        assert korean.shape != boxes.shape or not np.array_equal(korean, boxes)
    finally:
        v.close()


def test_pbs_view_lang_ko_without_a_hangul_font_is_one_line_exit_2(monkeypatch, capsys):
    """With no font with Hangul glyphs, ``pbs view --lang ko`` stops before opening a
    window: one line naming the package to install, exit 2."""
    from app import cli
    from app.walkthrough import labels

    monkeypatch.setattr(labels, "_fc_match", lambda pattern: None)
    labels.find_font.cache_clear()
    try:
        assert cli.main(["view", "--lang", "ko"]) == 2
    finally:
        labels.find_font.cache_clear()
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fonts-noto-cjk" in err


# --- idle and Escape ---------------------------------------------------------------------------


def _xdotool(*args: str) -> subprocess.Popen:
    if shutil.which("xdotool") is None:
        pytest.fail("xdotool is missing: run `bash scripts/dev.sh setup` (it installs it)")
    return subprocess.Popen(["xdotool", *args])


def _step_while(v, proc: subprocess.Popen, seconds: float = 10.0) -> None:
    """Frames while xdotool delivers its input, and a few after."""
    deadline = time.monotonic() + seconds
    while proc.poll() is None and time.monotonic() < deadline:
        v.step()
    v.step(3)
    assert proc.returncode == 0


def test_an_idle_window_draws_no_frames_and_input_wakes_it(viewer):
    """``run`` with nothing happening draws no frame in 2 s (a count, not a time: the
    loop sleeps in glfw.wait_events_timeout); a real mouse move over the window wakes it
    for a few frames, and a scene edit draws again."""
    import glfw

    v = viewer
    v.run(1.0)  # the settle frames after the fixture's input
    frames = v.frames
    v.run(2.0)
    assert v.frames == frames, f"{v.frames - frames} frames drawn while idle"
    window = str(glfw.get_x11_window(v.window))
    mover = _xdotool("mousemove", "--window", window, "40", "40", "sleep", "0.1",
                     "mousemove", "--window", window, "60", "50")  # fmt: skip
    v.run(1.5)
    assert mover.wait(10) == 0
    woken = v.frames - frames
    assert 0 < woken <= 20, woken
    v.edit({"materials.ball.roughness": 0.6})
    frames = v.frames
    v.run(1.0)
    assert v.frames > frames
    assert not v.state.dirty


def test_escape_quits_while_a_widget_is_held_and_ends_typing_first(xdisplay, scene_copy):
    """Real key presses (xdotool) on the X server, in a 960x540 window: Escape quits while
    a panel's button is held down (ImGui has the keyboard: an active widget); in the
    save-as text field the first Escape ends the typing and the second quits."""

    from app.viewer.window import Viewer

    v = Viewer(scene_copy, (960, 540), vsync=False)
    try:
        v.settle()
        v.step(3)
        _escape(v)
    finally:
        v.close()


def _escape(v) -> None:
    import glfw

    window = str(glfw.get_x11_window(v.window))

    def centre(name: str) -> tuple[str, str]:
        x0, y0, x1, y1 = v.panels.rects[name]
        return str(round((x0 + x1) / 2)), str(round((y0 + y1) / 2))

    x, y = centre("frame")
    _step_while(v, _xdotool("mousemove", "--window", window, x, y, "mousedown", "1",
                            "sleep", "0.3"))  # fmt: skip
    assert v.panels.wants_keyboard() and not v.panels.typing()  # the button is active
    _step_while(v, _xdotool("key", "--window", window, "Escape"))
    assert glfw.window_should_close(v.window)
    _step_while(v, _xdotool("mouseup", "1"))
    glfw.set_window_should_close(v.window, False)
    x, y = centre("save")
    _step_while(v, _xdotool("mousemove", "--window", window, x, y, "click", "1",
                            "sleep", "0.2", "type", "--window", window, "abc"))  # fmt: skip
    assert v.panels.typing() and v.panels.save_path == "abc"
    _step_while(v, _xdotool("key", "--window", window, "Escape"))
    assert not glfw.window_should_close(v.window) and not v.panels.typing()
    _step_while(v, _xdotool("key", "--window", window, "Escape"))
    assert glfw.window_should_close(v.window)


@pytest.mark.parametrize("size", [(960, 540), (1600, 900)])
def test_no_panel_covers_the_image_and_no_label_passes_a_panels_edge(xdisplay, size, lesson_steps):
    """At 960x540 and 1600x900: the image area is the window left of the docked column
    (the whole height, at least half the width) and the renderer renders at its size;
    every panel, each brought to the front in turn (the gold material with every section
    open, every walkthrough step with its lists), draws no item past its right edge (a
    label there would be cut)."""
    from app.viewer.window import Selection, Viewer

    v = Viewer(scenes_dir() / "showcase.toml", size, vsync=False)
    try:
        v.settle()
        x, y, w, h = v.image_rect
        assert (x, y, h) == (0, 0, size[1]) and size[0] / 2 <= w < size[0]
        assert v.renderer.size == (w, h)
        gold = next(i for i, o in enumerate(v.scene.objects) if o.material == "gold")
        v.selection = Selection(gold, "gold")
        v.panels.open_sections = True
        seen = {}
        for title in ("Material", "Lights", "Render", "Plots", "Compare"):
            v.panels.expand(title)
            v.step(3)
            seen[title] = v.panels.overflow[title]
        assert v.open_walkthrough(lesson_steps, "en", 1)
        for index in range(len(lesson_steps)):
            assert v.lesson.go(index)
            if v.lesson.current.step.sweeps:
                assert v.lesson.select_sweep(0)  # its slider and play drawn too
            v.step(3)
            seen[f"step {index + 1}"] = v.panels.overflow["Walkthrough"]
        seen["Scene"], seen["Problems"] = v.panels.overflow["Scene"], v.panels.overflow["Problems"]
        assert v.image_rect[2] == w  # the lesson's layout keeps the column's width
        cut = {title: round(px) for title, px in seen.items() if px > 0.5}
        assert not cut, f"items past the panel's edge (pixels): {cut}"
    finally:
        v.close()


# --- the sensor fit, the image area's rows, a transparent background ---------------------------

NARROW = (720, 405)  # the panels' column leaves the image area narrower than 16:9


@pytest.fixture
def showcase(xdisplay: str, tmp_path: Path):
    """The showcase (a 1280x720 scene: two rows of spheres across the frame) in a window
    whose image area, beside the panels, is narrower than the scene."""
    from app.viewer.window import Viewer

    path = tmp_path / "showcase.toml"
    shutil.copy(scenes_dir() / "showcase.toml", path)
    v = Viewer(path, NARROW, vsync=False)
    v.settle()
    yield v
    v.close()


def _shown_at(v, point) -> tuple[float, float]:
    """Where a world point falls in the window (pixels from the top-left) through the
    projection the drawn frame was rendered with (the renderer's, not the document's)."""
    ix, iy, w, h = v.image_rect
    clip = v.renderer.proj @ v.renderer.view @ np.array([*point, 1.0])
    return ix + (clip[0] / clip[3] * 0.5 + 0.5) * w, iy + (0.5 - clip[1] / clip[3] * 0.5) * h


def _row_ends(scene) -> list[int]:
    """The leftmost and rightmost sphere of each row (front: radius 0.6, back: 0.42)."""
    ends = []
    for radius in (0.6, 0.42):
        row = [i for i, o in enumerate(scene.objects) if o.shape == "sphere" and o.radius == radius]
        ends += [min(row, key=lambda i: scene.objects[i].position[0]),
                 max(row, key=lambda i: scene.objects[i].position[0])]  # fmt: skip
    return ends


def test_a_narrow_image_area_shows_the_scenes_whole_width(showcase):
    """Sensor fit: in an image area narrower than the scene's 16:9 the drawn frame widens
    its vertical field of view so that its horizontal extent is the scene's own, so the
    outermost sphere of each row lies inside the image (its centre projected with the
    drawn frame's matrices) and a click there picks it (picking reads the same frame); the
    document keeps fov_y 40, under which those spheres would fall outside the area. A real
    click (xdotool) on the leftmost metal sphere selects it. With the panels hidden the
    area is 16:9 again and the frame is the scene's own."""
    import glfw

    from app.frame.camera import projection_matrix, view_matrix

    v = showcase
    ix, iy, w, h = v.image_rect
    scene_aspect = v.scene.render.width / v.scene.render.height
    assert w / h < scene_aspect - 0.2
    assert v.scene.camera.fov_y == 40.0  # the document's camera
    cam = v.scene.camera
    own = projection_matrix(cam, w / h) @ view_matrix(cam)
    for index in _row_ends(v.scene):
        centre = v.scene.objects[index].position
        x, y = _shown_at(v, centre)
        assert ix + 2 <= x < ix + w - 2 and iy <= y < iy + h, (index, x, y)
        chosen = v.select_pixel(x, y)
        assert chosen.object_index == index, (index, chosen)
        clip = own @ np.array([*centre, 1.0])
        assert abs(clip[0] / clip[3]) > 1.0  # the scene's own fov_y would cut it off
    shown = v.renderer.camera.tan_half_fov  # the framing's width is the scene's own
    assert shown[0] == pytest.approx(np.tan(np.radians(20.0)) * scene_aspect)
    left = _row_ends(v.scene)[2]  # the back row's leftmost, nearest the image's edge
    v.selection = type(v.selection)()
    x, y = _shown_at(v, v.scene.objects[left].position)
    window = str(glfw.get_x11_window(v.window))
    _step_while(v, _xdotool("mousemove", "--window", window, str(round(x)), str(round(y)),
                            "click", "1"))  # fmt: skip
    assert v.selection.object_index == left
    v.show_ui = False  # Tab: the image is the whole 16:9 window
    v.settle()
    assert v.image_size == NARROW and v.renderer.scene.camera.fov_y == 40.0


def test_a_pan_in_the_fitted_frame_keeps_the_point_under_the_cursor(showcase):
    """A pan of 40 pixels in the narrow area moves the point at the target's depth by 40
    pixels in the drawn frame (metres per pixel from the displayed field of view, not the
    scene's narrower one)."""
    v = showcase
    target = v.scene.camera.target
    x0, y0 = _shown_at(v, target)
    v.pan(40, 0)
    v.settle()
    x1, y1 = _shown_at(v, target)
    assert (x1 - x0, y1 - y0) == (pytest.approx(40.0, abs=0.05), pytest.approx(0.0, abs=0.05))


def test_the_fitted_scene_keeps_the_files_policy(tmp_path):
    """The scene the window hands its renderer (``fit_scene``) reads its files under the
    document's policy (``--allow-path``, ``--max-memory``), not the default one."""
    from app.untrusted.policy import InputPolicy

    policy = InputPolicy.from_options([tmp_path], 1 << 30)
    loaded = load_scene(scenes_dir() / "showcase.toml", policy=policy)
    fitted = fit_scene(loaded, NARROW[::-1])
    assert fitted.scene.camera.fov_y > loaded.scene.camera.fov_y
    assert fitted.policy is policy


def test_viewing_keeps_the_scenes_fov_and_the_area_is_the_fitted_frame(showcase, gl_egl, tmp_path):
    """After an orbit, a pan and a zoom in the narrow area, the saved scene has the file's
    fov_y (the fit is the window's, not the document's) and the camera the window moved;
    the image area, every row from its top, is the renderer's frame pixel for pixel, and
    that frame is ``pbs render --fit``'s of the saved scene at the area's size (within
    1/255). The dark rows at the top are the scene's own: its background colour where no
    surface is, past the floor's far edge."""
    v = showcase
    v.orbit(30, -10)
    v.pan(12, 4)
    v.zoom(-0.5)
    v.settle()
    out = tmp_path / "saved.toml"
    v.save_scene(out)
    loaded = load_scene(out)
    assert loaded.scene.camera.fov_y == 40.0 and loaded.scene == v.scene
    ix, iy, w, h = v.image_rect
    area = v.read_window()[iy : iy + h, ix : ix + w]
    frame = v.renderer.read_ldr()
    assert frame.shape == area.shape
    assert np.array_equal(area[:32], frame[:32])  # the top rows: no strip of anything else
    assert np.array_equal(area, frame)
    assert_close(area, headless(gl_egl, fit_scene(loaded, (w, h)), (w, h)))
    assert not v.renderer.read_gbuffer().covered[:4].any()  # no surface: the background


def _checkerboard(shape: tuple[int, int]) -> np.ndarray:
    """The viewer's checkerboard under a transparent frame, rows from the top of an
    image area of ``shape`` (its squares start at the area's lower-left corner)."""
    from app.viewer.window import CHECKER, CHECKER_GREYS

    h, w = shape
    rows = (h - 1 - np.arange(h))[:, None] // CHECKER  # GL rows count from the bottom
    cols = np.arange(w)[None, :] // CHECKER
    return np.where((rows + cols) % 2 == 0, *CHECKER_GREYS).astype(np.float64)


def _srgb_decode(c: np.ndarray) -> np.ndarray:
    c = c / 255.0
    return np.where(c < 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _srgb_encode(c: np.ndarray) -> np.ndarray:
    s = np.where(c < 0.0031308, c * 12.92, 1.055 * np.power(np.maximum(c, 0.0), 1 / 2.4) - 0.055)
    return np.clip(np.round(s * 255.0), 0, 255)


def test_a_transparent_background_shows_over_a_checkerboard(showcase, tmp_path):
    """``render.background = "transparent"`` (the Render panel's background combo makes
    this edit): where no surface covers a pixel the window shows the checkerboard, not
    black; elsewhere the frame's colour mixed over it by its alpha in linear light (1/255);
    "opaque" brings the scene's background back; a screenshot is RGBA, as ``pbs render``'s."""
    from PIL import Image

    from app.viewer.panels import BACKGROUNDS

    v = showcase
    assert BACKGROUNDS == ("opaque", "transparent")
    v.show_ui = False
    v.settle()
    opaque = v.read_window()
    assert v.edit({"render.background": "transparent"})
    shown = window_image(v)
    rgba = v.renderer.read_rgba()
    alpha = rgba[..., 3:].astype(np.float64) / 255.0
    under = _srgb_decode(_checkerboard(shown.shape[:2]))[..., None]
    want = _srgb_encode(
        alpha * _srgb_decode(rgba[..., :3].astype(np.float64)) + (1 - alpha) * under
    )
    assert (alpha == 0).any() and (alpha == 1).any()
    assert_close(shown, want.astype(np.uint8))
    empty = alpha[..., 0] == 0
    assert set(np.unique(shown[empty])) == {153, 204}  # the checkerboard's two greys
    assert not np.array_equal(shown[empty], opaque[empty])
    path = v.screenshot(tmp_path / "shot.png")
    assert Image.open(path).mode == "RGBA"
    assert v.edit({"render.background": "opaque"})
    assert np.array_equal(window_image(v), opaque)


def test_walkthrough_reveal_shows_the_answer_and_its_view(viewer, lesson_steps):
    """Every step's questions draw hidden; "Reveal" shows the answer with the numbers the
    twins compute (none left as a place) and opens the question's view; a step change
    hides them again."""
    from app.walkthrough.questions import formatted

    v = viewer
    assert v.open_walkthrough(lesson_steps, "ko", 1)
    for index in range(len(lesson_steps)):
        assert v.lesson.go(index)
        questions = v.lesson.current.step.questions
        assert questions and not v.lesson.revealed
        for i, q in enumerate(questions):
            assert v.lesson.reveal(i)
            v.step(2)
            assert not v.state.error, (v.lesson.current.slug, v.state.error)
            text = v.lesson.answer(i)
            assert "{=" not in text
            assert all(shown in text for shown in formatted(q.numbers))
            if q.view is not None:
                want = v.lesson.path(v.lesson.current.step.views[q.view].scene)
                assert v.document.path == want
        assert v.lesson.revealed == set(range(len(questions)))
    assert v.lesson.previous() and not v.lesson.revealed
