"""The desktop viewer: a glfw window showing what ``Renderer`` renders, with Dear ImGui panels.

The viewer shades nothing itself. Each frame it hands its edits to the one ``Renderer`` that
``pbs render`` also runs (G-buffer -> culling -> lighting -> post), then draws the display
image into the window 1:1 and the panels over it. Everything the panels can do is a method
here, so scripts and tests drive the same code as the mouse:

    viewer = Viewer(Path("scenes/showcase.toml"))
    viewer.orbit(120, 0)                                   # a drag of 120 pixels
    viewer.edit({"materials.gold.roughness": 0.3})         # validated like a scene file
    viewer.step()                                          # one frame
    image = viewer.read_window()                           # the window's pixels

**Layout.** The panels sit in a docked side column (app/viewer/panels.py); the image fills
the rest, ``image_rect``: the renderer renders at that rectangle's size (so the camera's
aspect is the area's), the window draws it there 1:1, and a click maps into it. Without the
panels (Tab, ``ui=False``) the image is the whole window.

**Sensor fit.** The renderer is handed the scene with its vertical field of view fitted to
the image area (``display_scene``: ``fit_scene``, as ``pbs render --fit``): an area
narrower than the scene's render.width x render.height keeps the framing's whole width
(Blender's and f3d's viewports keep the framed scene in view). The document keeps the
file's fov_y: a save, orbit, pan and zoom never see the fitted one. Picking reads the drawn
frame's camera, so a click lands where the frame shows it.

**Alpha.** A transparent background's frame is shown over a checkerboard (``_Present``).

**Idle.** ``run`` draws a frame only when one would differ from the last: input arrived
(the panels get ``UI_SETTLE_FRAMES`` more to settle hover and focus), an edit or a pending
compile, a resize, the full-size frame after a preview, a played sweep, or an image still
refining (``refining``): with ``render.antialiasing = "jitter"`` each change draws jittered
sample 0 and the idle frames after it add samples 1 .. N-1 to the mean
(``Renderer.render_sample``), then the loop sleeps on the finished image. Otherwise it sleeps
in ``glfw.wait_events_timeout`` until an event or the next hot-reload check, so an idle
window costs no frames (docs/viewer.md measures its CPU).

**Escape** quits, whatever has the focus, except while a text field is being typed into:
then the first Escape ends the typing (ImGui's own cancel) and the second quits, as a
console in f3d takes the first Escape: a half-typed file name is not a reason to lose the
session, and nothing else swallows the key.

**Responsive on a software rasteriser.** While input arrives the renderer runs at
1/``PREVIEW_SCALE`` of the window's size; ``REFINE_AFTER`` seconds after the last input it
renders once more at full size (docs/viewer.md measures the latency). An edit that may need
new shader programs (a model, a light type, a setting) is applied one frame late: first the
last image is shown with a "compiling..." notice, then the edit runs.

**Hot reload.** The scene file and the GLSL tree are watched (``WATCH_INTERVAL``); a change
reloads them. A scene that no longer validates, or GLSL that no longer compiles, leaves the
last good state running and shows the error (file and line) in the Problems panel.
"""

from __future__ import annotations

import copy
import ctypes
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import glfw
import moderngl
import numpy as np

from app.errors import InputError
from app.frame.camera import fit_scene
from app.gl.context import GLContext
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderError
from app.output import write_hdr, write_png
from app.reference.position import reconstruct_position
from app.reference.raycast import intersect_sphere
from app.render.compare import CompareSpec, Comparison
from app.render.debug_views import DEBUG_VIEWS, LIGHT_VIEWS, DebugPass
from app.render.renderer import Renderer, RenderOptions
from app.resources import glsl_dir, scenes_dir
from app.scene.edits import get_key
from app.scene.loader import LoadedScene
from app.scene.model import Camera
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy
from app.viewer import orbit as orbit_controls
from app.viewer import x11
from app.viewer.document import SceneDocument, mesh_scene
from app.viewer.host import Selection, ViewerState

PREVIEW_SCALE = 2  # while interacting: render at 1/2 of the window in each direction
REFINE_AFTER = 0.25  # seconds without input before the full-size frame
WATCH_INTERVAL = 0.5  # seconds between checks of the scene file and glsl/
DIVIDER_GRAB = 6  # pixels either side of a split's divider that a drag moves it by
DIVIDER_DRAG = -1  # the drag "button" of a divider drag
UI_SETTLE_FRAMES = 3  # frames drawn after an input event, for ImGui's hover and focus
# A transparent frame is shown over a checkerboard, as image editors show alpha: squares of
# CHECKER pixels in two light greys (sRGB-encoded 8-bit values).
# A new area light's size keys (docs/area_lights.md): what add_light gives each shape.
AREA_LIGHT_DEFAULTS: dict[str, dict[str, Any]] = {
    "rect": {"size": [1.0, 0.5]},
    "disk": {"radius": 0.4},
    "sphere": {"radius": 0.25},
    "tube": {"radius": 0.05, "length": 1.0},
}
CHECKER = 8
# The viewer's frames are interactive ones: they leave out render.gbaa_interior (its cost;
# a still, `pbs render`, draws it where the scene asks; docs/antialiasing.md)
INTERACTIVE = RenderOptions(interactive=True)
CHECKER_GREYS = (204, 153)


# A split placed on the compared object (``split_on_difference``): the column profile of
# the sides' difference smoothed over 1/SPLIT_SMOOTH of the width; its median column is
# on what they differ on where the profile there keeps SPLIT_ON of its peak; else the
# runs of columns above SPLIT_RUN of the peak are the objects to choose from.
SPLIT_SMOOTH = 64
SPLIT_ON = 0.05
SPLIT_RUN = 0.25


def split_on_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Where a split of the display images ``a`` and ``b`` (H, W, 3) should fall, a
    fraction of the width: the median column of their difference (half of it on either
    side: a compared sphere's middle, a spot's pool's, a glint's), or, where the sides
    hardly differ there (the difference on objects apart), the middle of the differing
    object nearest to it, so that what is compared straddles the divider wherever the
    image puts it; 0.5 where the sides are the same."""
    diff = np.abs(a[..., :3].astype(np.float32) - b[..., :3].astype(np.float32))
    profile = diff.sum(axis=(0, 2), dtype=np.float64)
    width = len(profile)
    if not profile.max() > 0.0:
        return 0.5
    half = max(width // SPLIT_SMOOTH, 1)
    smooth = np.convolve(profile, np.ones(2 * half + 1) / (2 * half + 1), mode="same")
    peak = float(smooth.max())
    total = np.cumsum(profile)
    median = int(np.searchsorted(total, 0.5 * total[-1]))
    if smooth[median] >= SPLIT_ON * peak:
        return (median + 0.5) / width
    inside = np.concatenate([[False], smooth >= SPLIT_RUN * peak, [False]])
    edges = np.flatnonzero(np.diff(inside.astype(np.int8)))
    runs = list(zip(edges[::2], edges[1::2], strict=True))
    left, right = min(runs, key=lambda run: abs((run[0] + run[1]) / 2.0 - median))
    return (left + right) / 2.0 / width


class ViewerError(RuntimeError):
    """The window cannot be opened (no display, no OpenGL 3.3)."""


def _problem(exc: BaseException) -> str:
    """One line for the Problems panel: an input error as the CLI prints it, a GLSL error
    after "GLSL:", anything else with its type."""
    if isinstance(exc, InputError):
        text = str(exc)
    elif isinstance(exc, ShaderError | moderngl.Error):
        text = f"GLSL: {exc}"
    else:
        text = f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _on_x11() -> bool:
    """Whether glfw runs on X11 (the viewer's X error handlers apply only there)."""
    get_platform = getattr(glfw, "get_platform", None)
    return get_platform is None or get_platform() == getattr(glfw, "PLATFORM_X11", None)


def _release_current_egl() -> None:
    """Unbind a headless EGL context current in this thread (``pbs render``'s, a test's):
    Mesa refuses to make a GLX window context current over it (BadAccess)."""
    try:
        egl = ctypes.CDLL("libEGL.so.1")
    except OSError:
        return
    egl.eglGetCurrentContext.restype = ctypes.c_void_p
    egl.eglGetCurrentDisplay.restype = ctypes.c_void_p
    if egl.eglGetCurrentContext():
        egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        egl.eglMakeCurrent(egl.eglGetCurrentDisplay(), None, None, None)


def _glsl_mtime() -> float:
    return max((p.stat().st_mtime for p in glsl_dir().rglob("*") if p.is_file()), default=0.0)


class Viewer:
    """One window on one scene (see the module docstring)."""

    def __init__(
        self,
        scene: Path | None = None,
        size: tuple[int, int] = (960, 540),
        *,
        visible: bool = True,
        vsync: bool = True,
        ui: bool = True,
        hangul: bool = False,
        policy: InputPolicy = DEFAULT_POLICY,
        data: dict | None = None,
    ) -> None:
        """``data``: the scene's keys where it is not read from ``scene`` (a model file's
        scene, saved as ``scene``). ``hangul`` merges a Hangul font into the panels'
        (``Panels.load_hangul``): for the Korean walkthrough, asked for before the first
        frame. ``policy``: what the scenes' files may reach and cost (``--allow-path``,
        ``--max-memory``)."""
        self.document = SceneDocument(scene or scenes_dir() / "showcase.toml", data, policy)
        self.base_camera = self.document.scene.camera  # what "reset camera" goes back to
        if not glfw.init():
            raise ViewerError("glfw could not initialise (is there a display? DISPLAY unset?)")
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SCALE_TO_MONITOR, True)  # HiDPI: the window grows with the scale
        glfw.window_hint(glfw.VISIBLE, visible)
        _release_current_egl()  # glfw makes the new context current while creating it
        self.window = glfw.create_window(size[0], size[1], self._title(), None, None)
        if not self.window:
            glfw.terminate()
            raise ViewerError("could not open an OpenGL 3.3 core window")
        glfw.make_context_current(self.window)
        # A window destroyed or a connection killed from outside ends the viewer cleanly
        # (app/viewer/x11.py) instead of Xlib's exit(1).
        self._x11 = x11.watch(glfw.get_x11_window(self.window)) if _on_x11() else None
        self.vsync = vsync
        glfw.swap_interval(1 if vsync else 0)
        self.gl = GLContext(moderngl.create_context(require=330), "glfw")
        self.ctx = self.gl.ctx
        self.state = ViewerState(glsl_mtime=_glsl_mtime(), last_watch=time.perf_counter())
        self.selection = Selection()
        self.show_ui = ui
        self.panels = None  # until the panels exist (below), the image is the whole window
        self.renderer = Renderer(
            self.gl, self.display_scene(), self.image_size, options=INTERACTIVE
        )
        self.comparison: Comparison | None = None
        self.compare_mode: str = "split"  # or "difference"
        self.divider = 0.5  # where the split falls, a fraction of the width
        self._place_divider = False  # the next frame puts it on the sides' difference
        self.gain = 8.0  # the difference view's magnification
        self.debug_view: str | None = None  # a view of app/render/debug_views.py
        self.debug_light = 0
        self._debug: DebugPass | None = None
        self._present = _Present(self.ctx)
        self._drag: tuple[int, float, float] | None = None  # button, last x, last y
        self.lesson = None  # the walkthrough (app/viewer/lesson.py), when one is open
        self.frames = 0  # frames drawn and swapped (an idle window draws none)
        self._settle = UI_SETTLE_FRAMES  # frames still to draw for the panels to settle
        # Progressive refinement: a callable that says whether another frame of the same
        # scene state would still improve the image; while it does, ``run`` keeps
        # rendering. Default: jittered samples still to add (``_samples_left``).
        self.refining: Callable[[], bool] = self._samples_left
        self._sample = 0  # the next jittered sample of the progressive mean
        if ui:
            from app.viewer.panels import Panels

            self.panels = Panels(self)
            if hangul:
                self.panels.load_hangul()
        self._install_callbacks()
        if self.panels is not None:  # the docked layout (sized on its second frame), so
            for _ in range(2):  # that image_size is the image area's from the start
                self.panels.draw()

    # --- sizes and the image --------------------------------------------------------------

    @property
    def framebuffer_size(self) -> tuple[int, int]:
        """The window's size in pixels (on HiDPI screens larger than in screen units)."""
        w, h = glfw.get_framebuffer_size(self.window)
        return max(int(w), 1), max(int(h), 1)

    @property
    def image_rect(self) -> tuple[int, int, int, int]:
        """Where the image is drawn, framebuffer pixels (x, y from the top, w, h): the
        docked layout's central node, or the whole window without panels."""
        size = self.framebuffer_size
        if self.panels is None or not self.show_ui:
            return 0, 0, size[0], size[1]
        return self.panels.image_rect(size)

    @property
    def image_size(self) -> tuple[int, int]:
        """The image area's size in pixels: what the renderer renders at full size."""
        return self.image_rect[2:]

    @property
    def scene(self):
        return self.document.scene

    def display_scene(self, loaded: LoadedScene | None = None) -> LoadedScene:
        """``loaded`` (default: the document's scene) as the window shows it: its camera's
        vertical field of view fitted to the image area (the sensor fit, ``fit_scene``, as
        ``pbs render --fit`` does), so that an area narrower than the scene's own
        render.width x render.height keeps the framing's whole width; a wider one keeps
        fov_y. Only the renderer gets this camera: the document, what a save writes and
        what orbit, pan and zoom edit, keeps the scene's own fov_y."""
        return fit_scene(self.document.loaded if loaded is None else loaded, self.image_size)

    def _title(self) -> str:
        return f"pbs view - {self.document.path.name}"

    # --- edits ----------------------------------------------------------------------------

    def edit(self, changes: dict[str, Any], *, defer: bool | None = None) -> bool:
        """Apply {key path: value} edits of the scene data (``None`` removes a key). A
        refused value leaves everything as it was and puts the CLI's message in
        ``error``; returns whether the edit was taken. ``defer`` (default: for edits that
        may compile programs) applies it one frame later, behind the notice."""
        self.touch()
        if defer is None:
            defer = any(_structural(key) for key in changes)
        if defer:
            try:  # validate now, so a refused value is reported at once
                self._validated(changes)
            except InputError as exc:
                self.state.error = str(exc)
                return False
            self.state.pending.append(changes)
            self.state.notice = "compiling..."
            return True
        return self._apply(changes)

    def _validated(self, changes: dict[str, Any]) -> LoadedScene:
        return self.document.edited(changes)[1]

    def _apply(self, changes: dict[str, Any]) -> bool:
        self._current()
        old = self.document.scene
        previous = copy.deepcopy(self.document.data)
        try:
            loaded = self.document.edit(changes)
        except InputError as exc:
            self.state.error = str(exc)
            return False
        self.state.error = ""
        try:
            camera_only = loaded.scene.model_copy(update={"camera": old.camera}) == old
            shown = self.display_scene(loaded)
            if camera_only:
                self.renderer.set_camera(shown.scene.camera)
            else:
                self.renderer.update(shown.scene)
            if self.comparison is not None:
                if camera_only:
                    self.comparison.set_camera(shown.scene.camera)
                else:
                    self.comparison.update_base(shown)
        except InputError as exc:  # the edit is valid, but not on a comparison's side
            self.document.replace(previous)
            self._rebuild()
            self.state.error = str(exc)
            return False
        except (ShaderError, moderngl.Error) as exc:
            self.document.replace(previous)
            self._rebuild()  # the renderer may be half-updated: rebuild the last good state
            self.state.error = f"GLSL: {exc}"
            return False
        self.state.dirty = True
        return True

    def set_camera(self, camera: Camera) -> None:
        """Show the scene from ``camera`` (kept in the scene, so saving keeps the view)."""
        self._apply(
            {
                "camera.position": list(camera.position),
                "camera.target": list(camera.target),
                "camera.up": list(camera.up),
            }
        )

    def orbit(self, dx: float, dy: float) -> None:
        """A left-drag of (dx, dy) pixels: turn around the target."""
        self.touch()
        self.set_camera(orbit_controls.orbit(self.scene.camera, dx, dy, self.image_size[1]))

    def pan(self, dx: float, dy: float) -> None:
        """A right- or shift-drag of (dx, dy) pixels: slide in the view plane."""
        self.touch()
        fov_y = self.display_scene().scene.camera.fov_y  # the cursor's point follows it
        self.set_camera(
            orbit_controls.pan(self.scene.camera, dx, dy, self.image_size[1], fov_y)
        )  # fmt: skip

    def zoom(self, steps: float) -> None:
        """Wheel steps towards the target (negative: away)."""
        self.touch()
        self.set_camera(orbit_controls.zoom(self.scene.camera, steps))

    def reset_camera(self) -> None:
        self.touch()
        self.set_camera(self.base_camera)

    def frame_selection(self) -> None:
        """Frame the selected object (the whole scene when nothing is selected)."""
        self.touch()
        parts = self.renderer.frame.parts
        chosen = [
            p for p in parts
            if self.selection.object_index is None or p.object_index == self.selection.object_index
        ]  # fmt: skip
        if not chosen:
            return
        points = np.concatenate(
            [p.surface_points() @ p.model[:3, :3].T + p.model[:3, 3] for p in chosen]
        )  # fmt: skip
        lo, hi = points.min(axis=0), points.max(axis=0)
        centre = (lo + hi) / 2.0
        radius = float(np.linalg.norm(hi - lo) / 2.0) or 1.0
        self.set_camera(orbit_controls.frame(self.scene.camera, centre, radius))

    def select_pixel(self, x: float, y: float) -> Selection:
        """Select the object and material under window pixel (x, y), y down from the top:
        the first surface the pixel's view ray meets (the one the G-buffer shows there;
        nothing where the G-buffer holds no surface or the pixel is outside the image)."""
        self._current()
        r = self.comparison.renderers[0] if self.comparison is not None else self.renderer
        ix, iy, fw, fh = self.image_rect
        x, y = x - ix, y - iy
        if not (0 <= x < fw and 0 <= y < fh):
            self.selection = Selection()
            return self.selection
        w, h = r.render_size
        px = min(int(x * w / fw), w - 1)
        py = min(int((fh - 1 - y) * h / fh), h - 1)  # GL rows bottom-up
        depth = r.gbuffer.depth_at(px, py)
        if not (np.isfinite(depth) and depth > 0.0):
            self.selection = Selection()
            return self.selection
        ndc = np.array([(px + 0.5) / w * 2.0 - 1.0, (py + 0.5) / h * 2.0 - 1.0])
        cam = r.camera
        p = reconstruct_position(ndc, np.float64(depth), cam.position, cam.camera_to_world,
                                 cam.tan_half_fov)  # fmt: skip
        origin = np.asarray(cam.position, np.float64)
        direction = (p - origin) / np.linalg.norm(p - origin)
        best, nearest, own = None, np.inf, None
        for part in r.frame.parts:
            t = _nearest_hit(origin, direction, part)
            if t < nearest:
                best, nearest, own = part.object_index, t, part.file_material
        material = self.scene.objects[best].material if best is not None else None
        self.selection = Selection(best, material, own if material is None else None)
        return self.selection

    def add_light(self, kind: str) -> bool:
        """A new light of ``kind`` ("directional", "point", "spot", or an area light:
        "rect", "disk", "sphere", "tube", with a size of its own) 2 m above the camera's
        target, pointing down."""
        target = [float(x) for x in self.scene.camera.target]
        above = [target[0], target[1] + 2.0, target[2]]
        light: dict[str, Any] = {"type": kind, "intensity": 1.0 if kind == "directional" else 4.0}
        light.update(AREA_LIGHT_DEFAULTS.get(kind, {}))
        if kind not in ("point", "sphere"):
            light["direction"] = [0.0, -1.0, -0.2]
        if kind != "directional":
            light["position"] = above
        lights = [*copy.deepcopy(self.document.data.get("lights", [])), light]
        return self.edit({"lights": lights})

    def remove_light(self, index: int) -> bool:
        lights = copy.deepcopy(self.document.data.get("lights", []))
        del lights[index]
        return self.edit({"lights": lights})

    def compare(
        self,
        key: str,
        a: Any,
        b: Any,
        mode: str = "split",
        divider: float | None = 0.5,
        gain: float = 8.0,
    ) -> bool:
        """Show the scene with two values of one key side by side (``mode`` "split", the
        divider at ``divider`` of the width, or, with None, on the object the sides differ
        on most, placed from the first frame's images: ``split_on_difference``; drag it in
        the window) or as their difference magnified by ``gain`` (docs/compare.md). A key
        or value the scene refuses is reported and nothing changes."""
        self._current()
        self.touch()
        try:
            spec = CompareSpec(key, a, b, origin="compare")
            comparison = Comparison(
                self.gl, self.display_scene(), spec, self.renderer.size, self.renderer.options
            )
        except (InputError, ShaderError, moderngl.Error) as exc:
            return self._refuse(exc)
        self.stop_compare()
        self.comparison = comparison
        self.compare_mode, self.gain = mode, float(gain)
        self.divider = 0.5 if divider is None else float(divider)
        self._place_divider = divider is None
        self.state.error = ""
        self.state.dirty = True
        return True

    def open_walkthrough(
        self, steps: list | None = None, lang: str | None = None, section: int = 1
    ) -> bool:
        """Open the classroom walkthrough (default: the bundled steps, validated first) on
        the step of RTR4 §9.``section`` in ``lang`` ("en" or "ko"; Korean merges the Hangul
        font); a step that does not load is reported and nothing changes."""
        from app.viewer.lesson import Lesson

        if steps is None:
            from app.resources import walkthrough_dir
            from app.walkthrough.model import load_walkthrough

            try:
                steps = load_walkthrough(walkthrough_dir())
            except InputError as exc:
                return self._refuse(exc)
        if lang is None:
            korean = self.panels is not None and self.panels.hangul  # pbs view --lang ko
            lang = self.lesson.lang if self.lesson is not None else "ko" if korean else "en"
        if lang == "ko" and self.panels is not None and not self.panels.load_hangul():
            lang = "en"
        if self.lesson is not None:
            self.lesson.close()
        self.lesson = Lesson(self, steps, lang)
        if self.panels is not None:
            self.panels.relayout()  # the Walkthrough docked above the other panels
            self.panels.expand("Walkthrough")
        return self.lesson.go_section(section)

    def _refuse(self, exc: Exception) -> bool:
        """Report what refused an action in the Problems panel; nothing changed."""
        self.state.error = _problem(exc)
        return False

    def stop_compare(self) -> None:
        """Back to the single image."""
        self._current()
        if self.comparison is not None:
            self.comparison.release()
            self.comparison = None
            self.state.dirty = True

    def set_debug_view(self, view: str | None, light: int = 0) -> bool:
        """Show a debug view of the frame (``pbs render --debug VIEW``; None: the render),
        ``light`` indexing ``renderer.lights`` for the BRDF views; a bad one is reported."""
        if view is not None and view not in DEBUG_VIEWS:
            self.state.error = f"unknown debug view '{view}' (one of {', '.join(DEBUG_VIEWS)})"
            return False
        if view in LIGHT_VIEWS and not 0 <= light < len(self.renderer.lights):
            self.state.error = (
                f"--debug-light: {light} is not a light of the frame "
                f"(0 .. {len(self.renderer.lights) - 1})"
            )
            return False
        self.debug_view, self.debug_light = view, int(light)
        self.state.error = ""
        self.state.dirty = True
        return True

    def set_divider(self, divider: float) -> None:
        self.divider = float(np.clip(divider, 0.0, 1.0))
        self._place_divider = False
        self.state.dirty = True

    def set_vsync(self, on: bool) -> None:
        self.vsync = on
        glfw.swap_interval(1 if on else 0)

    def _current(self) -> None:
        """Make the window's GL context current: a process may hold other contexts (a
        headless renderer, a test's), and every GL call here must reach this one."""
        if glfw.get_current_context() != self.window:
            _release_current_egl()
            glfw.make_context_current(self.window)

    def touch(self) -> None:
        """Note user input: the next frames render at preview size."""
        self.state.last_input = time.perf_counter()

    # --- files ------------------------------------------------------------------------------

    def save_scene(self, path: Path | None = None) -> Path:
        """Write the edited scene as TOML (default: over the scene file)."""
        path = Path(path) if path is not None else self.document.path
        self.document.save(path)
        return path

    def screenshot(self, path: Path | None = None, hdr: bool = False) -> Path:
        """The full-size image as shown (the image area's size and fitted camera; PNG,
        RGBA with a transparent background; with ``hdr`` also the linear radiance as .exr)
        next to the scene unless ``path`` says otherwise."""
        self._current()
        self._render(scale=1)
        while self.comparison is None and self._mean_unfinished():  # the whole mean
            self._render(scale=1)
        stem = self.document.path.with_suffix("")
        path = Path(path) if path is not None else stem.parent / f"{stem.name}-view.png"
        write_png(path, self.renderer.read_image())  # RGBA where transparent, as pbs render
        if hdr:
            write_hdr(path.with_suffix(".exr"), self.renderer.read_hdr_image())
        return path

    def open_scene(self, path: Path) -> bool:
        """Show another scene file, or a mesh file (.obj, .gltf, .glb, ... in a scene of
        its own: ``mesh_scene``) as a dropped file does; a bad one is reported and
        nothing changes."""
        self._current()
        path = Path(path).resolve()
        policy = self.document.policy
        try:
            if path.suffix.lower() == ".toml":
                document = SceneDocument(path, policy=policy)
            else:
                data = mesh_scene(path)
                name = path.with_name(f"{path.stem}-view.toml")
                document = SceneDocument(name, data, policy)
            renderer = Renderer(self.gl, fit_scene(document.loaded, self.image_size),
                                self.image_size, options=INTERACTIVE)  # fmt: skip
        except Exception as exc:
            return self._refuse(exc)
        self.stop_compare()  # a comparison of the old scene would hide the new one
        self.renderer.release()
        self.document, self.renderer = document, renderer
        self.base_camera = document.scene.camera
        self.selection = Selection()
        self.state.error = ""
        self.state.dirty = True
        glfw.set_window_title(self.window, self._title())
        if path.suffix.lower() != ".toml":
            self.frame_selection()  # the whole mesh in view
            self.base_camera = self.scene.camera
        return True

    def _watch(self) -> None:
        """Hot reload: the scene file and glsl/, at most every WATCH_INTERVAL seconds."""
        now = time.perf_counter()
        if now - self.state.last_watch < WATCH_INTERVAL:
            return
        self.state.last_watch = now
        if self.document.changed_on_disk():
            old, previous = self.document.scene, copy.deepcopy(self.document.data)
            try:
                loaded = self.document.reload()
            except Exception as exc:
                self.state.error = _problem(exc)
            else:
                self.state.error = ""
                if loaded.scene != old and not self._rebuild():
                    self.document.replace(previous)  # the last good scene stays edited
        mtime = _glsl_mtime()
        if mtime != self.state.glsl_mtime:
            self.state.glsl_mtime = mtime
            self._rebuild()

    def _rebuild(self) -> bool:
        """A new renderer from the document (new programs from the GLSL on disk, its files
        read again); on any error (GLSL that does not compile, a mesh, texture or
        environment that cannot be read) the old one keeps running, the error is shown,
        and False is returned."""
        self._current()
        try:
            renderer = Renderer(self.gl, self.display_scene(), self.image_size, options=INTERACTIVE)
        except Exception as exc:
            self.state.error = _problem(exc)
            return False
        self.renderer.release()
        self.renderer = renderer
        self.state.error = ""
        self.state.dirty = True
        return True

    # --- frames ---------------------------------------------------------------------------

    def _render(self, scale: int) -> None:
        """Render at the image area's size / scale if anything changed since the last
        frame (or the renderer is still refining)."""
        fw, fh = self.image_size
        size = (max(fw // scale, 1), max(fh // scale, 1))
        if self.renderer.size != size:
            self.renderer.resize(size)
            self.state.dirty = True
        if self.comparison is not None and self.comparison.size != size:
            self.comparison.resize(size)
            self.state.dirty = True
        self._fit_camera()
        refining = self.comparison is None and self.refining()
        if not (self.state.dirty or self.state.rendered_scale != scale or refining):
            return
        changed = self.state.dirty or self.state.rendered_scale != scale
        if self.comparison is not None:  # the two sides, composited; the base is not drawn
            self.comparison.render()
            if self._place_divider:  # on the object the sides differ on most
                a, b = (side.read_ldr() for side in self.comparison.renderers)
                self.divider, self._place_divider = split_on_difference(a, b), False
            self.comparison.composite(self.compare_mode, self.divider, self.gain)
        else:
            timings: dict[str, float] = {}
            asked = timings if self.panels and self.panels.timing else None
            if self._progressive():
                self._sample = 0 if changed else self._sample
                self.renderer.render_sample(self._sample, self._sample == 0, asked)
                self._sample += 1
            else:
                self.renderer.render(asked)
            if timings:
                self.state.frame_ms = timings
            if self.debug_view is not None:
                self._run_debug()
        self.state.dirty = False
        self.state.rendered_scale = scale

    def _fit_camera(self) -> None:
        """Give the renderer (and a comparison's sides) the camera fitted to the image
        area's aspect now (``display_scene``): the area changes with the window, the
        panels' column and Tab. The full-size area decides, so that the preview (half of
        it, rounded down) shows the same field of view."""
        camera = self.display_scene().scene.camera
        if self.renderer.scene.camera != camera:
            self.renderer.set_camera(camera)
            self.state.dirty = True
        if self.comparison is not None and self.comparison.base.scene.camera != camera:
            self.comparison.set_camera(camera)
            self.state.dirty = True

    def _sample_count(self) -> int:
        """The jittered samples of the progressive mean (``render.antialiasing = "jitter"``
        on a renderer with ``render_sample``), else 1: one ``render()`` a change."""
        if getattr(self.renderer, "accumulate", None) is None:
            return 1
        return int(getattr(self.scene.render, "antialiasing_samples", 1))

    def _progressive(self) -> bool:
        """Whether frames are drawn as samples of a progressive mean (not for a debug
        view, which reads the last frame's G-buffer and light terms)."""
        return self.debug_view is None and self._sample_count() > 1

    def _mean_unfinished(self) -> bool:
        """Whether the progressive mean drawn last still lacks samples."""
        return self._progressive() and 0 < self._sample < self._sample_count()

    def _samples_left(self) -> bool:
        """Whether the full-size image still lacks samples of its mean (never while a
        preview is shown: input is arriving, each change restarts at sample 0)."""
        return self.state.rendered_scale == 1 and self._scale() == 1 and self._mean_unfinished()

    @property
    def window_gone(self) -> bool:
        """Whether X destroyed the window under the viewer (closed from outside)."""
        return self._x11 is not None and self._x11.gone

    def step(self, frames: int = 1) -> None:
        """Run ``frames`` frames: input, hot reload, pending edits, render, panels, swap."""
        self._current()
        for _ in range(frames):
            glfw.poll_events()
            # A round trip to the X server (the window's size) makes it report a window
            # destroyed from outside now, before the panels ask for its size mid-frame.
            glfw.get_window_size(self.window)
            if self.window_gone:  # destroyed from outside: the loop ends, nothing drawn
                glfw.set_window_should_close(self.window, True)
                return
            self._watch()
            if self.state.pending and self.state.notice:
                self._draw()  # the last image with the notice, before the compile
                self._swap()
                self.state.notice = ""
                continue
            while self.state.pending:
                self._apply(self.state.pending.pop(0))
            if self.lesson is not None:
                self.lesson.tick()  # a played sweep's next value
            self._render(self._scale())
            self._draw()
            self._swap()

    def _scale(self) -> int:
        """The scale to render at now: the preview while input is recent, else full size."""
        interacting = time.perf_counter() - self.state.last_input < REFINE_AFTER
        return PREVIEW_SCALE if interacting else 1

    def _swap(self) -> None:
        glfw.swap_buffers(self.window)
        self.frames += 1
        self._settle = max(self._settle - 1, 0)

    def settle(self) -> None:
        """Frames until every pending edit is applied and the full-size image is shown
        (what a script wants before reading the window)."""
        self.state.last_input = 0.0
        while self.state.pending or self.state.notice:
            self.step()
        self.step()
        for _ in range(3):  # the panels' first frame moves the image area: once more
            if not self.state.dirty:
                break
            self.step()
        while self.comparison is None and self.refining():  # the whole progressive mean
            self.step()

    def needs_frame(self) -> bool:
        """Whether a frame now would show something the last one did not (module
        docstring, "Idle")."""
        s = self.state
        return bool(
            self._settle
            or s.dirty
            or s.pending
            or s.notice
            or s.rendered_scale != self._scale()
            or (self.lesson is not None and self.lesson.playing)
            or (self.comparison is None and self.refining())
        )

    def _idle_wait(self, until: float | None) -> float:
        """Seconds to sleep for events: to the next hot-reload check, the full-size frame
        after a preview, or ``until``, whichever is first."""
        now = time.perf_counter()
        wake = [self.state.last_watch + WATCH_INTERVAL]
        if self.state.rendered_scale != 1:
            wake.append(self.state.last_input + REFINE_AFTER)
        if until is not None:
            wake.append(until)
        return min(max(min(wake) - now, 0.0), WATCH_INTERVAL)

    def run(self, seconds: float | None = None) -> None:
        """The interactive loop, until the window is closed (or for ``seconds``): a frame
        when ``needs_frame``, else a sleep until an event arrives."""
        until = None if seconds is None else time.perf_counter() + seconds
        while not glfw.window_should_close(self.window):
            if until is not None and time.perf_counter() >= until:
                return
            if self.needs_frame():
                self.step()
                continue
            self._current()
            glfw.wait_events_timeout(self._idle_wait(until))
            if self.window_gone:
                glfw.set_window_should_close(self.window, True)
                return
            self._watch()  # hot reload marks the state dirty when a file changed

    def _draw(self) -> None:
        """The image into ``image_rect``, the panels around it."""
        fw, fh = self.framebuffer_size
        x, y, w, h = self.image_rect
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, fw, fh)
        if (w, h) != (fw, fh):
            self.ctx.clear(0.0, 0.0, 0.0)  # what the panels leave uncovered stays dark
        self.ctx.viewport = (x, fh - y - h, w, h)  # GL rows from the bottom
        self._present.draw(self._shown(), (x, fh - y - h, w, h), self._shows_alpha())
        self.ctx.viewport = (0, 0, fw, fh)
        if self.panels is not None and self.show_ui:
            try:
                self.panels.draw()
            except RuntimeError:  # ImGui's check of the window's size, the window gone
                if not self.window_gone:
                    raise

    def _run_debug(self) -> None:
        """The debug view of the frame just rendered, on a DebugPass of this renderer at
        this size (made again when either changed)."""
        r = self.renderer
        if (
            self._debug is None
            or self._debug.renderer is not r
            or self._debug.size != r.render_size
        ):
            if self._debug is not None:
                self._debug.release()
            self._debug = DebugPass(r)
        if self.debug_view in LIGHT_VIEWS and self.debug_light >= len(r.lights):
            self.debug_light = 0  # its light was removed
        self._debug.run(self.debug_view, self.debug_light)

    def _shown(self) -> moderngl.Texture:
        """The display image of the last render: the comparison's composite while one is
        shown, a debug view's, else the renderer's (never a texture a rebuilt pass has
        released)."""
        if self.comparison is not None and self.comparison.last_target is not None:
            return self.comparison.last_target
        if self.debug_view is not None and self._debug is not None and self._debug.view:
            return self._debug.display
        return self.renderer.post.target

    def _shows_alpha(self) -> bool:
        """Whether the image shown carries a coverage alpha to show over the checkerboard:
        a transparent background's frame (``render.background = "transparent"``), or a
        split comparison of one (the split copies each side's alpha); not a debug view
        or the difference view, whose alpha is 1."""
        if self.comparison is not None:
            transparent = any(r.transparent for r in self.comparison.renderers)
            return transparent and self.compare_mode == "split"  # an opaque side: alpha 1
        return self.renderer.transparent and self._shown() is self.renderer.post.target

    def read_window(self) -> np.ndarray:
        """The window's framebuffer as the last frame drew it, (H, W, 3) uint8, rows top
        to bottom."""
        self._current()
        fw, fh = self.framebuffer_size
        data = self.ctx.screen.read(viewport=(0, 0, fw, fh), components=3)
        return np.frombuffer(data, np.uint8).reshape(fh, fw, 3)[::-1].copy()

    def value(self, key: str, default: Any = None) -> Any:
        """A value of the edited scene data (what a scene file would hold)."""
        return get_key(self.document.data, key, default)

    # --- input ------------------------------------------------------------------------------

    def _install_callbacks(self) -> None:
        glfw.set_mouse_button_callback(self.window, self._on_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)
        glfw.set_scroll_callback(self.window, self._on_scroll)
        glfw.set_key_callback(self.window, self._on_key)
        glfw.set_drop_callback(self.window, self._on_drop)
        glfw.set_framebuffer_size_callback(self.window, lambda *_: self._on_resize())
        # Events only the panels read: each wakes the idle loop for a few frames.
        glfw.set_char_callback(self.window, lambda *_: self._wake())
        glfw.set_cursor_enter_callback(self.window, lambda *_: self._wake())
        glfw.set_window_focus_callback(self.window, lambda *_: self._wake())
        glfw.set_window_refresh_callback(self.window, lambda *_: self._wake())
        if self.panels is not None:
            self.panels.install_backend(ctypes.cast(self.window, ctypes.c_void_p).value)

    def _wake(self) -> None:
        """An input event: draw ``UI_SETTLE_FRAMES`` frames (the panels react to it)."""
        self._settle = UI_SETTLE_FRAMES

    def _ui_wants_mouse(self) -> bool:
        return self.panels is not None and self.show_ui and self.panels.wants_mouse()

    def _on_button(self, window, button: int, action: int, mods: int) -> None:
        self._wake()
        if action == glfw.PRESS and not self._ui_wants_mouse():
            x, y = glfw.get_cursor_pos(window)
            self._drag = (button, x, y)
            self._press = (x, y)
            px = self._to_pixels(x, y)[0]
            if self._on_divider(px) and button == glfw.MOUSE_BUTTON_LEFT:
                self._drag = (DIVIDER_DRAG, x, y)
        elif action == glfw.RELEASE and self._drag is not None:
            x, y = glfw.get_cursor_pos(window)
            px, py = getattr(self, "_press", (x, y))
            click = abs(x - px) + abs(y - py) < 3
            if button == glfw.MOUSE_BUTTON_LEFT and click and self._drag[0] != DIVIDER_DRAG:
                self.select_pixel(*self._to_pixels(x, y))  # a click, not a drag
            self._drag = None

    def _on_divider(self, x: float) -> bool:
        """Whether window pixel column x grabs the split's divider."""
        if self.comparison is None or self.compare_mode != "split":
            return False
        ix, _, w, _ = self.image_rect
        return abs(x - ix - self.divider * w) <= DIVIDER_GRAB

    def _to_pixels(self, x: float, y: float) -> tuple[float, float]:
        """Screen units (cursor) to framebuffer pixels (HiDPI)."""
        ww, wh = glfw.get_window_size(self.window)
        fw, fh = self.framebuffer_size
        return x * fw / max(ww, 1), y * fh / max(wh, 1)

    def _on_cursor(self, window, x: float, y: float) -> None:
        self._wake()
        if self._drag is None:
            return
        button, lx, ly = self._drag
        self._drag = (button, x, y)
        if button == DIVIDER_DRAG:
            self.touch()
            ix, _, w, _ = self.image_rect
            self.set_divider((self._to_pixels(x, y)[0] - ix) / w)
            return
        dx, dy = self._to_pixels(x - lx, y - ly)
        shift = glfw.get_key(window, glfw.KEY_LEFT_SHIFT) == glfw.PRESS
        if button == glfw.MOUSE_BUTTON_LEFT and not shift:
            self.orbit(dx, dy)
        else:
            self.pan(dx, dy)

    def _on_scroll(self, window, dx: float, dy: float) -> None:
        self._wake()
        if not self._ui_wants_mouse():
            self.zoom(dy)

    def _on_key(self, window, key: int, scancode: int, action: int, mods: int) -> None:
        self._wake()
        if action not in (glfw.PRESS, glfw.REPEAT):
            return
        ui = self.panels is not None and self.show_ui
        if key == glfw.KEY_ESCAPE and action == glfw.PRESS:
            if not (ui and self.panels.typing()):  # typing: ImGui's Escape ends it first
                glfw.set_window_should_close(window, True)
            return
        if ui and self.panels.wants_keyboard():
            return
        step = 20.0  # pixels of drag per key press
        moves = {
            glfw.KEY_LEFT: lambda: self.orbit(-step, 0),
            glfw.KEY_RIGHT: lambda: self.orbit(step, 0),
            glfw.KEY_UP: lambda: self.orbit(0, -step),
            glfw.KEY_DOWN: lambda: self.orbit(0, step),
            glfw.KEY_EQUAL: lambda: self.zoom(1),
            glfw.KEY_MINUS: lambda: self.zoom(-1),
            glfw.KEY_F: self.frame_selection,
            glfw.KEY_R: self.reset_camera,
            glfw.KEY_TAB: self._toggle_ui,
        }
        if key == glfw.KEY_S and mods & glfw.MOD_CONTROL:
            self.save_scene()
        elif key == glfw.KEY_P or key == glfw.KEY_F12:
            self.screenshot(hdr=bool(mods & glfw.MOD_SHIFT))
        elif key in (glfw.KEY_PAGE_UP, glfw.KEY_PAGE_DOWN) and self.lesson is not None:
            self.lesson.go(self.lesson.index + (1 if key == glfw.KEY_PAGE_DOWN else -1))
        elif key in moves:
            moves[key]()

    def _toggle_ui(self) -> None:
        self.show_ui = not self.show_ui

    def _on_drop(self, window, paths: list[str]) -> None:
        """A scene or mesh file dropped on the window opens (the first, if several)."""
        if paths:
            self.open_scene(Path(paths[0]))

    def _on_resize(self) -> None:
        self._wake()
        self.touch()
        self.state.dirty = True

    def close(self) -> None:
        if self.window_gone:  # nothing of the window is left to release or draw into
            glfw.terminate()
            return
        self._current()
        if self.panels is not None:
            self.panels.shutdown()
        if self.lesson is not None:
            self.lesson.close()  # its formula textures
        self.stop_compare()
        if self._debug is not None:
            self._debug.release()
        self.renderer.release()
        self._present.release()
        glfw.destroy_window(self.window)
        glfw.terminate()


class _Present:
    """Draws the renderer's display image into a rectangle of the window (the viewport the
    caller set): texel-exact (NEAREST) when the image has the rectangle's size, bilinear
    when a preview is magnified. An image with a coverage alpha (a transparent background)
    is composited over a checkerboard of ``CHECKER`` pixel squares fixed to the
    rectangle's lower-left corner: straight alpha, blended in linear light (the sRGB
    curve, IEC 61966-2-1, undone and redone), as coverage mixes radiance. The draw is
    app/gl/fullscreen.py's ``FullscreenDraw`` with the window's own small program (no
    shader cache or project header: the default framebuffer is all it writes)."""

    _VERTEX = """
#version 330 core
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
    _FRAGMENT = """
#version 330 core
uniform sampler2D u_image;
uniform vec2 u_origin;  // the rectangle's lower-left corner, window pixels
uniform vec2 u_size;    // its size
uniform int u_alpha;    // 1: the image's straight alpha over the checkerboard; 0: opaque
uniform float u_checker;       // the checkerboard's square, pixels
uniform vec2 u_checker_greys;  // its two greys, sRGB-encoded
out vec4 frag_color;
vec3 srgb_to_linear(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(0.04045, c));
}
vec3 linear_to_srgb(vec3 c) {
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
    vec2 local = gl_FragCoord.xy - u_origin;
    vec4 texel = texture(u_image, local / u_size);
    if (u_alpha == 0) {
        frag_color = vec4(texel.rgb, 1.0);
        return;
    }
    ivec2 cell = ivec2(floor(local / u_checker));
    float grey = ((cell.x + cell.y) & 1) == 0 ? u_checker_greys.x : u_checker_greys.y;
    vec3 under = srgb_to_linear(vec3(grey));
    vec3 over = srgb_to_linear(texel.rgb);
    frag_color = vec4(linear_to_srgb(mix(under, over, texel.a)), 1.0);
}
"""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        program = ctx.program(vertex_shader=self._VERTEX, fragment_shader=self._FRAGMENT)
        self.fullscreen = FullscreenDraw(ctx, program, owns_program=True)
        self.nearest = ctx.sampler(filter=(moderngl.NEAREST, moderngl.NEAREST), repeat_x=False,
                                   repeat_y=False)  # fmt: skip
        self.linear = ctx.sampler(filter=(moderngl.LINEAR, moderngl.LINEAR), repeat_x=False,
                                  repeat_y=False)  # fmt: skip

    def draw(
        self, image: moderngl.Texture, rect: tuple[int, int, int, int], alpha: bool = False
    ) -> None:
        """``image`` over ``rect`` (x, y from the bottom, w, h: the viewport set); with
        ``alpha``, its alpha over the checkerboard."""
        x, y, w, h = rect
        sampler = self.nearest if image.size == (w, h) else self.linear
        self.ctx.disable(moderngl.CULL_FACE)  # the draw disables depth test and blending
        sampler.use(0)
        uniforms = {
            "u_origin": (float(x), float(y)),
            "u_size": (float(w), float(h)),
            "u_alpha": int(alpha),
            "u_checker": float(CHECKER),
            "u_checker_greys": tuple(g / 255.0 for g in CHECKER_GREYS),
        }
        self.fullscreen.draw(None, uniforms, {"u_image": image})
        sampler.clear(0)

    def release(self) -> None:
        self.fullscreen.release()
        for obj in (self.nearest, self.linear):
            obj.release()


def _nearest_hit(origin: np.ndarray, direction: np.ndarray, part) -> float:
    """Distance along a ray to the nearest triangle of a mesh part, inf for a miss
    (Moller & Trumbore 1997, vectorised over the triangles, two-sided); for an analytic
    sphere, to its exact front surface (the ray-caster's intersection)."""
    if part.analytic is not None and part.analytic.kind == "sphere":
        inv = np.linalg.inv(part.model)
        o = inv[:3, :3] @ origin + inv[:3, 3]
        d = inv[:3, :3] @ direction  # the map is affine: t is the world distance
        return float(intersect_sphere(part.analytic.radius, o, d[None], 0.0, np.inf)[0])
    world = part.vertices[:, :3].astype(np.float64) @ part.model[:3, :3].T + part.model[:3, 3]
    tri = world[part.indices.reshape(-1, 3)]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pvec = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, pvec)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tvec = origin - tri[:, 0]
    u = np.einsum("ij,ij->i", tvec, pvec) * inv
    qvec = np.cross(tvec, e1)
    v = (qvec @ direction) * inv
    t = np.einsum("ij,ij->i", e2, qvec) * inv
    hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
    return float(t[hit].min()) if np.any(hit) else float("inf")


# Keys whose edit can change which programs a frame needs (model choices, maps, light kinds,
# pipeline settings): applied one frame late, behind the "compiling..." notice.
_STRUCTURAL = re.compile(
    r"^(render\.|objects|environment|lights$|lights\[\d+\]$|lights\[\d+\]\.type$|"
    r"materials\.[^.]+$|materials\.[^.]+\.(preset|fresnel|ndf|lambda_form|g2|correlation|"
    r"diffuse|multiscatter|anisotropy|blend|[a-z_]+_map|sheen|clearcoat_model|thin_film|"
    r"diffraction|fiber)$)"
)


# A model file's material factor: new constants on the same parts and maps, as a scene
# material's number (app.frame.restyle_file_materials), so not deferred as "objects" is.
# The emissive ones stay deferred: an emission turning on or off from black compiles the
# G-buffer and lighting programs again.
_FILE_FACTOR = re.compile(
    r"^objects\[\d+\]\.file_materials\..+\.(base_color|alpha|metallic|roughness)$"
)


def _structural(key: str) -> bool:
    """Whether an edit of ``key`` may need programs the renderer has not compiled."""
    return _STRUCTURAL.match(key) is not None and _FILE_FACTOR.match(key) is None
