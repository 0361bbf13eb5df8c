"""The viewer's Dear ImGui panels (imgui-bundle, drawn through the window's own GL context).

Each widget reads the edited scene (``Viewer.value``, or the resolved material for values a
preset supplies) and writes through ``Viewer.edit`` with the key path a scene file uses, so
a panel can do exactly what a scene file can, with the same validation and messages:

* Scene: objects, materials and lights; a click in the image selects what is under it.
* Material: the selected material's preset (searchable), parameters and model of each term.
* Lights: add, remove, move, colour, intensity, range, cone.
* Render: tone map, exposure, lens, G-buffer precision, culling, filtering, terms,
  background (opaque or transparent), vsync.
* Plots: the selected material's lobes and directional albedo from the GLSL probe that
  ``pbs brdf`` uses, and the frame time of each pass.
* Problems: the last refused edit, scene error or GLSL error (file and line).
* Walkthrough: the classroom lesson's step (app/viewer/lesson.py), when one is open.

**Layout.** The panels are docked (Dear ImGui docking) in a side column on the right: Scene
at the top, the other panels as tabs below it, Problems at the foot. The rest of the window,
the dock space's central node, is the image: the window draws the renderer's image there
(``image_rect``), sized and aspected to it, so no panel covers the scene, a picked object or
either half of a comparison. The column's width comes from the font's text sizes (the
longest control label and a widget beside it, the widest tab row), not from constants, and
every widget leaves its label that room (``push_item_width(-label)``), so no label is cut.
A user may still drag the column's edge or undock a panel; the image follows the central
node either way.

ImGui's default font has no Hangul: ``load_hangul`` merges a system font with Hangul
glyphs (the one the walkthrough's labels use) into it, only when Korean is asked for.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, get_args

import numpy as np
from imgui_bundle import imgui, implot

from app.common.gbuffer import ENCODING_NAMES
from app.common.material_fields import Control, scene_default, scene_keys
from app.common.models import (
    CLEARCOAT_MODELS,
    CLOTH_WRAP_FORMS,
    CORRELATIONS,
    DIFFUSE_MODELS,
    FIBER_MODELS,
    FRESNEL_MODELS,
    G2_MODELS,
    LAMBDA_FORMS,
    NDF_MODELS,
    SHEEN_MODELS,
)
from app.common.tonemaps import TONEMAPS
from app.errors import InputError
from app.render.debug_views import DEBUG_VIEWS, LIGHT_VIEWS
from app.scene.model import CLOTH_KEYS, FIBER_KEYS, SADEGHI_KEYS, TEXTURE_KEYS, RenderSettings
from app.scene.presets import PRESETS
from app.untrusted import RefusedError
from app.untrusted.policy import Limits
from app.untrusted.structured import parse_toml
from app.viewer.host import Selection

if TYPE_CHECKING:
    from app.viewer.host import ViewerHost

RED = imgui.ImVec4(1.0, 0.35, 0.3, 1.0)
AMBER = imgui.ImVec4(1.0, 0.8, 0.2, 1.0)
LOBE_ANGLES = (30.0, 60.0)  # incident angles of the lobe plot, degrees
VIEWS = ("split", "difference")  # the comparison's views
# render.background's values ("opaque", "transparent"), as the scene format declares them
BACKGROUNDS: tuple[str, ...] = get_args(RenderSettings.model_fields["background"].annotation)
# The docked layout: the top of the side column, its tabs below, the foot.
TOP = ("Scene",)
TABS = ("Walkthrough", "Material", "Lights", "Render", "Plots", "Compare")
FOOT = ("Problems",)
TOP_SHARE = 0.4  # at most, of the column's height above the tabs
LESSON_SHARE = 0.72  # of it while a walkthrough is open: the Walkthrough in front of Scene
FOOT_LINES = 3  # the Problems panel's height, lines of text (an error wraps to more)
SIDE_MAX = 0.5  # the column never takes more of the window's width than this
WIDGET_TEXT = "-0.000 -0.000 -0.000"  # what a widget beside its label should fit (a drag_float3)
# Labels of the panels' own widgets, for the label column's width; the Material panel's
# field labels come from the material-field table (``scene_keys``).
LABELS = (
    "index of refraction", "f0 (dielectric)", "medium index", "eta (R, G, B)",
    "k (R, G, B)", "blend threshold", "blend softness", "fibre model", "inner exponent",
    "sheen NDF", "coat model", "exposure (EV)", "field of view", "aperture (m)",
    "focus distance", "normal_filter", "light_culling", "supersample", "debug view",
    "of light", "intensity", "direction", "outer angle", "inner angle", "A (left)",
    "B (right)", "lambda_form", "correlation", "multiple scattering", "base colour",
    "size (m)", "radius (m)", "length (m)",
)  # fmt: skip


def _control(name: str) -> Control:
    """How the Material panel shows scene key ``name``: its label and range, declared with
    its material field (app/common/material_fields.py)."""
    control = scene_keys()[name].control
    if control is None:
        raise KeyError(f"{name}: the material-field table gives it no control")
    return control


def diffuse_edit(key: str, old: str, new: str) -> dict[str, Any]:
    """The edit that picks diffuse model ``new`` for material ``key``: the empirical cloth
    keys (refused without their model) leave with it."""
    edit: dict[str, Any] = {f"{key}.diffuse": new}
    if old == "cloth_empirical" and new != old:
        edit |= {f"{key}.{k}": None for k in CLOTH_KEYS}
    return edit


def fiber_edit(key: str, old: str, new: str) -> dict[str, Any]:
    """The edit that picks fibre model ``new`` for material ``key``: keys the new model
    does not take leave with the old one (all of them for "none", Sadeghi's own for
    Kajiya-Kay)."""
    edit: dict[str, Any] = {f"{key}.fiber": new}
    leaving = FIBER_KEYS if new == "none" else SADEGHI_KEYS if new != "sadeghi" else ()
    if old != new:
        edit |= {f"{key}.{k}": None for k in leaving}
    return edit


def grating_edit(key: str, on: bool) -> dict[str, Any]:
    """The edit that turns material ``key``'s diffraction grating on (the scene format's
    default period and depth) or off (its keys removed with it)."""
    if on:
        return {f"{key}.diffraction": "grating"}
    return {f"{key}.diffraction": "none", f"{key}.grating_period": None,
            f"{key}.grating_depth": None}  # fmt: skip


class Panels:
    """The ImGui context, its glfw/OpenGL3 backends and the panels' own state."""

    def __init__(self, viewer: ViewerHost) -> None:
        self.viewer = viewer
        self.context = imgui.create_context()
        self.plot_context = implot.create_context()
        imgui.get_io().set_ini_filename("")  # no imgui.ini next to the user's files
        self.preset_filter = ""
        self.save_path = ""
        self.timing = False  # the frame-time plot asks the renderer to time its passes
        # The Compare panel's fields: a key path and TOML values, as --compare takes them.
        self.compare_key = "render.normal_filter"
        self.compare_a, self.compare_b = '"naive"', '"variance"'
        self.compare_mode = 0
        self._curves: tuple[object, Any] | None = None  # (material key, (lobes, albedo))
        self._backend = False
        # Panels to bring to the front of their tabs, and for how many more frames (a
        # panel docked on its first frame takes its tab on the next).
        self._expand: dict[str, int] = {}
        self._selected: object = None  # the selection the panels last saw
        # The key path of the material the Material panel shows (None: none), and the
        # glTF files' own materials read for it (``_file_materials``).
        self.shown_material: str | None = None
        self._file_info: dict[tuple[str, float], tuple[list[str], list[dict[str, Any]]]] = {}
        # Every section of the Material panel (and Scene > Materials) drawn open (the docs'
        # screenshot and the tests that draw each material's controls).
        self.open_sections = False
        io = imgui.get_io()
        io.config_flags |= imgui.ConfigFlags_.docking_enable
        io.config_input_text_cursor_blink = False  # an idle viewer draws nothing
        self.dock_id = 0
        self._layout = False  # the dock layout is built (first frame, or again on request)
        self.side_width = 0.0  # the column's width, screen units (set with the layout)
        self.label_width = 0.0  # the label column every widget leaves free
        # The central node's rectangle in framebuffer pixels (x, y from the top, w, h):
        # where the window draws the image; None before the first frame.
        self.central: tuple[int, int, int, int] | None = None
        # Where a few widgets were drawn (screen units: x0, y0, x1, y1), for tests that
        # click them with real input: "save" (the save-as field), "frame" (its button).
        self.rects: dict[str, tuple[float, float, float, float]] = {}
        self._first_rect = (0.0, 0.0, 0.0, 0.0)  # the last row of buttons' first
        # Per panel, how many pixels its widest item passed its right edge when it was last
        # drawn (0 or less: nothing cut); tests read it at the window sizes they check.
        self.overflow: dict[str, float] = {}
        self.hangul = False  # a Hangul font merged into the default one (load_hangul)
        from app.viewer.lesson import LessonPanel

        self.lesson_panel = LessonPanel()

    def expand(self, *titles: str) -> None:
        """Open these panels (by title) on the next frame, e.g. Material after a click."""
        self._expand.update(dict.fromkeys(titles, 2))

    def load_hangul(self) -> bool:
        """Merge the system's Hangul font (``find_font("ko")``, Noto Sans CJK KR) into
        ImGui's default font; a missing one is reported in Problems. ImGui 1.92 rasterises
        glyphs into its atlas when they are first drawn, so no glyph range is listed and
        the atlas grows only by the Hangul actually shown (docs/viewer.md measures it)."""
        if self.hangul:
            return True
        from app.walkthrough.labels import find_font

        try:
            face = find_font("ko")
        except InputError as exc:
            self.viewer.state.error = str(exc)
            return False
        fonts = imgui.get_io().fonts
        if not fonts.fonts:
            fonts.add_font_default()  # what ImGui would add on its first frame
        config = imgui.ImFontConfig()
        config.merge_mode = True  # into the default font: Latin from it, Hangul from here
        config.font_no = face.index  # the KR face of the .ttc collection
        fonts.add_font_from_file_ttf(str(face.path), 0.0, config)  # the default size
        self.hangul = True
        return True

    def install_backend(self, window_address: int) -> None:
        """glfw input and OpenGL3 drawing for ImGui; it chains to the viewer's callbacks."""
        imgui.backends.glfw_init_for_opengl(window_address, True)
        imgui.backends.opengl3_init("#version 330 core")
        self._backend = True

    def wants_mouse(self) -> bool:
        return bool(imgui.get_io().want_capture_mouse)

    def wants_keyboard(self) -> bool:
        return bool(imgui.get_io().want_capture_keyboard)

    def typing(self) -> bool:
        """Whether a text field has the keyboard (Escape then ends the typing, not the
        viewer)."""
        return bool(imgui.get_io().want_text_input)

    def relayout(self) -> None:
        """Build the docked layout again on the next frame (panels back in their places)."""
        self._layout = False

    def image_rect(self, framebuffer: tuple[int, int]) -> tuple[int, int, int, int]:
        """Where the image goes in a framebuffer of this size: the central node's rectangle
        of the last frame (x, y from the top, w, h); before the first frame, the window
        less a column of ``SIDE_MAX`` / 2 of its width."""
        fw, fh = framebuffer
        if self.central is None:
            return 0, 0, max(fw - int(fw * SIDE_MAX / 2), 1), fh
        x, y, w, h = self.central
        x, y = min(max(x, 0), fw - 1), min(max(y, 0), fh - 1)
        return x, y, max(min(w, fw - x), 1), max(min(h, fh - y), 1)

    def shutdown(self) -> None:
        if self._backend:
            imgui.backends.opengl3_shutdown()
            imgui.backends.glfw_shutdown()
        implot.destroy_context(self.plot_context)
        imgui.destroy_context(self.context)

    # --- a frame of panels ------------------------------------------------------------------

    def draw(self) -> None:
        s = self.viewer.selection
        selected = (s.object_index, s.material, s.file_material)
        if selected != self._selected:
            self._selected = selected
            if selected[1] is not None or selected[2] is not None:
                self.expand("Material")
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        imgui.new_frame()
        self._dock_space()
        self._scene_panel()
        self._material_panel()
        self._lights_panel()
        self._render_panel()
        self._plots_panel()
        self._compare_panel()
        if self.viewer.lesson is not None:
            self.lesson_panel.draw(self.viewer.lesson, self)
        self._problems_panel()
        self._central_node()
        imgui.render()
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def _measure(self) -> None:
        """The label column and the side column's width, from the font's text sizes: the
        longest label beside a widget that fits ``WIDGET_TEXT``, or the row of tabs,
        whichever is wider, with the window's padding and a scrollbar."""
        style = imgui.get_style()
        labels = [*LABELS, *(c.label for k in scene_keys().values() if (c := k.control))]
        self.label_width = max(imgui.calc_text_size(t).x for t in labels)
        self.label_width += style.item_inner_spacing.x
        widget = imgui.calc_text_size(WIDGET_TEXT).x + 6 * style.frame_padding.x
        tab = 2 * style.frame_padding.x + style.item_inner_spacing.x
        tabs = sum(imgui.calc_text_size(t).x + tab for t in TABS)
        inner = max(self.label_width + widget, tabs)
        self.side_width = inner + 2 * style.window_padding.x + style.scrollbar_size

    def _dock_space(self) -> None:
        """The dock space over the whole window, its central node see-through (the image
        is drawn under it); its layout built on the first frame and on ``relayout``."""
        viewport = imgui.get_main_viewport()
        self.dock_id = imgui.get_id("pbs dock space")
        if not self._layout:
            self._build_layout(viewport)
        imgui.dock_space_over_viewport(
            self.dock_id, viewport, imgui.DockNodeFlags_.passthru_central_node
        )

    def _build_layout(self, viewport: Any) -> None:
        """Split the dock space: a column on the right of ``side_width`` (at most
        ``SIDE_MAX`` of the window), in it ``TOP``, the ``TABS`` and ``FOOT``; while a
        walkthrough is open, the Walkthrough joins the top, in front of Scene, and the top
        takes ``LESSON_SHARE`` of the column (the lesson's text is what is read then)."""
        internal = imgui.internal
        self._measure()
        dock = self.dock_id
        internal.dock_builder_remove_node(dock)
        internal.dock_builder_add_node(dock, internal.DockNodeFlagsPrivate_.dock_space)
        internal.dock_builder_set_node_size(dock, viewport.size)
        width, height = max(viewport.size.x, 1.0), max(viewport.size.y, 1.0)
        split = internal.dock_builder_split_node(
            dock, imgui.Dir.right, min(self.side_width / width, SIDE_MAX)
        )
        side = split.id_at_dir
        foot_h = imgui.get_frame_height() + FOOT_LINES * imgui.get_text_line_height_with_spacing()
        foot_h += 2 * imgui.get_style().window_padding.y
        split = internal.dock_builder_split_node(side, imgui.Dir.down, min(foot_h / height, 0.3))
        foot, rest = split.id_at_dir, split.id_at_opposite_dir
        # The Scene panel's height: its actions and its objects (a longer list scrolls).
        lines = len(self.viewer.scene.objects) + 8
        top_h = lines * imgui.get_frame_height_with_spacing()
        top_share = min(top_h / max(height - foot_h, 1.0), TOP_SHARE)
        top_titles, tab_titles = TOP, TABS
        if self.viewer.lesson is not None:
            top_share, top_titles = LESSON_SHARE, ("Walkthrough", *TOP)
            tab_titles = tuple(t for t in TABS if t != "Walkthrough")
        split = internal.dock_builder_split_node(rest, imgui.Dir.up, top_share)
        top, tabs = split.id_at_dir, split.id_at_opposite_dir
        for titles, node in ((top_titles, top), (tab_titles, tabs), (FOOT, foot)):
            for title in titles:
                internal.dock_builder_dock_window(title, node)
        internal.dock_builder_finish(dock)
        self._layout = True

    def _central_node(self) -> None:
        """Note the central node's rectangle in framebuffer pixels (``image_rect``)."""
        node = imgui.internal.dock_builder_get_central_node(self.dock_id)
        if node is None:
            return
        sx, sy = imgui.get_io().display_framebuffer_scale
        sx, sy = sx or 1.0, sy or 1.0
        rect = (round(node.pos.x * sx), round(node.pos.y * sy), round(node.size.x * sx),
                round(node.size.y * sy))  # fmt: skip
        if rect != self.central:
            self.central = rect
            self.viewer.state.dirty = True  # the image is rendered again at its new size

    def _window(self, title: str) -> bool:
        """Begin a panel (docked by the layout); a panel ``expand`` asked for comes to the
        front of its tabs. Every widget leaves ``label_width`` for its label."""
        if title in self._expand:
            self._expand[title] -= 1
            if not self._expand[title]:
                del self._expand[title]
            imgui.set_next_window_focus()
        visible = imgui.begin(title)[0]
        imgui.push_item_width(-self.label_width)
        return visible

    def _end(self) -> None:
        """End a panel, noting how far its widest item passed the panel's right edge
        (``overflow``: above 0, something in it is cut)."""
        imgui.pop_item_width()
        window = imgui.internal.get_current_window()
        if not window.skip_items:  # drawn this frame (a docked panel behind a tab is not)
            self.overflow[window.name] = window.dc.cursor_max_pos.x - window.work_rect.max.x
        imgui.end()

    def _buttons(self, *labels: str, small: bool = False) -> str | None:
        """A row of buttons that wraps where the next one would not fit; the label of the
        one clicked, or None."""
        style = imgui.get_style()
        clicked = None
        for i, label in enumerate(labels):
            width = imgui.calc_text_size(label.split("##")[0]).x + 2 * style.frame_padding.x
            if i > 0:  # the cursor is at the next line's start: its right edge is the row's
                right = imgui.get_cursor_screen_pos().x + imgui.get_content_region_avail().x
                if imgui.get_item_rect_max().x + style.item_spacing.x + width <= right:
                    imgui.same_line()
            if (imgui.small_button if small else imgui.button)(label):
                clicked = label
            if i == 0:
                lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
                self._first_rect = (lo.x, lo.y, hi.x, hi.y)
        return clicked

    def _section(self, label: str) -> bool:
        """A collapsing header of the Material panel (held open by ``open_sections``)."""
        if self.open_sections:
            imgui.set_next_item_open(True, imgui.Cond_.always)
        return imgui.collapsing_header(label)

    def _key_slider(
        self, key: str, material: Any, field: str, label: str, default: float,
        low: float, high: float, flags: int = 0,
    ) -> None:  # fmt: skip
        """A slider for one number of material ``key``; an unset key shows its default."""
        now = getattr(material, field)
        changed, value = imgui.slider_float(
            label, default if now is None else float(now), low, high, flags=flags
        )
        if changed:
            self._edit(f"{key}.{field}", float(value))

    def _field_slider(self, key: str, material: Any, name: str) -> None:
        """The slider of scene key ``name`` of material ``key``: its label, range and
        default from the material row's declaration (app/common/material_fields.py)."""
        control = _control(name)
        flags = imgui.SliderFlags_.logarithmic if control.logarithmic else 0
        default = float(scene_default(name))  # type: ignore[arg-type]
        self._key_slider(
            key, material, name, control.label, default, control.low, control.high, flags
        )

    def _field_color(self, key: str, material: Any, name: str) -> None:
        """The colour editor of scene key ``name`` of material ``key`` (unset: its default)."""
        rgb = getattr(material, name) or scene_default(name)
        changed, rgb = imgui.color_edit3(_control(name).label, [float(c) for c in rgb])
        if changed:
            self._edit(f"{key}.{name}", [float(c) for c in rgb])

    def _edit(self, key: str, value: Any) -> None:
        self.viewer.edit({key: value})

    def _scene_panel(self) -> None:
        v = self.viewer
        if self._window("Scene"):
            imgui.text(v.document.path.name)
            clicked = self._buttons("Frame (F)", "Reset camera (R)")
            self.rects["frame"] = self._first_rect
            if clicked == "Frame (F)":
                v.frame_selection()
            elif clicked == "Reset camera (R)":
                v.reset_camera()
            imgui.set_next_item_width(-1)  # no label: the whole row
            _, self.save_path = imgui.input_text_with_hint(
                "##save", "save as... (empty: over the file)", self.save_path
            )
            lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
            self.rects["save"] = (lo.x, lo.y, hi.x, hi.y)
            clicked = self._buttons("Save scene (Ctrl+S)", "Screenshot (P)", "Lesson")
            if clicked == "Save scene (Ctrl+S)":
                v.save_scene(self.save_path or None)
            elif clicked == "Screenshot (P)":
                v.screenshot()
            elif clicked == "Lesson":
                v.open_walkthrough()
            if imgui.collapsing_header("Objects", imgui.TreeNodeFlags_.default_open):
                for i, obj in enumerate(v.scene.objects):
                    own = self._file_materials(i)
                    label = f"{obj.name or obj.shape} #{i}  ({obj.material or 'default'})"
                    if obj.material is None and own is not None:
                        label = f"{obj.name or Path(obj.file or '').name} #{i}  (file's)"
                    chosen = v.selection.object_index == i
                    if imgui.selectable(label, chosen)[0]:
                        first = own[0][0] if own and own[0] and obj.material is None else None
                        v.selection = Selection(i, obj.material, first)
            if self.open_sections:
                imgui.set_next_item_open(True, imgui.Cond_.always)
            if imgui.collapsing_header("Materials"):
                for name in v.scene.materials:
                    if imgui.selectable(name, v.selection.material == name)[0]:
                        v.selection.material, v.selection.file_material = name, None
                # A model file's own materials (an object without ``material``), each
                # edited under that object's ``file_materials``.
                for i, obj in enumerate(v.scene.objects):
                    own = self._file_materials(i) if obj.material is None else None
                    for name in own[0] if own else ():
                        chosen = (v.selection.object_index, v.selection.file_material)
                        if imgui.selectable(f"{name}  (#{i}'s file)", chosen == (i, name))[0]:
                            v.selection = Selection(i, None, name)
        self._end()

    def _file_materials(self, index: int) -> tuple[list[str], list[dict[str, Any]]] | None:
        """Object ``index``'s glTF file's material keys and their own factors
        (app/scene/file_materials.py); None for another object or a file that cannot be
        read (the scene's own error says why). Kept per file and modification time."""
        from app.scene.file_materials import material_keys, own_factors
        from app.scene.geometry import GLTF_SUFFIXES

        v = self.viewer
        obj = v.scene.objects[index]
        if obj.file is None or not obj.file.lower().endswith(GLTF_SUFFIXES):
            return None
        try:
            path = v.document.loaded.resolve_file(obj.file, f"objects[{index}].file")
            stamp = (str(path), path.stat().st_mtime)
        except (InputError, OSError):
            return None
        if stamp not in self._file_info:
            from app.scene.gltf_document import GltfError, open_gltf

            try:
                materials = open_gltf(path, v.document.policy).materials or []
            except (GltfError, InputError, RefusedError, OSError):
                return None
            keys = material_keys(materials)
            self._file_info[stamp] = (keys, [own_factors(m) for m in materials])
        return self._file_info[stamp]

    def _material_panel(self) -> None:
        v = self.viewer
        name = v.selection.material
        if self._window("Material"):
            index, own = v.selection.object_index, v.selection.file_material
            self.shown_material = None
            if name is not None and name in v.scene.materials:
                self._material_editor(name)
                self.shown_material = f"materials.{name}"
            elif index is not None and own is not None and index < len(v.scene.objects):
                self._file_material_editor(index, own)
            else:
                imgui.text_wrapped("Click an object, or pick a material in Scene.")
        self._end()

    def _file_material_editor(self, index: int, name: str) -> None:
        """The factors of object ``index``'s glTF file's own material ``name``, edited as
        ``objects[index].file_materials."name".<key>`` (app/scene/model.py
        ``FileMaterial``): each shows the scene's override, else the file's value."""
        from app.scene.file_materials import key_path

        v = self.viewer
        info = self._file_materials(index)
        if info is None or name not in info[0]:
            imgui.text_wrapped("Click an object, or pick a material in Scene.")
            return
        own = info[1][info[0].index(name)]
        given = (v.scene.objects[index].file_materials or {}).get(name)
        key = key_path(index, name)
        self.shown_material = key
        imgui.text(f"{name}  (#{index}'s file)")
        imgui.text_disabled("glTF factors; the file's maps multiply them")

        def now(field: str) -> Any:
            value = None if given is None else getattr(given, field)
            return own[field] if value is None else value

        for field, label in (("base_color", "base colour"), ("emissive", "emissive")):
            changed, rgb = imgui.color_edit3(label, [float(c) for c in now(field)])
            if changed:
                self._edit(f"{key}.{field}", [min(max(float(c), 0.0), 1.0) for c in rgb])
        for field, high, flags in (
            ("alpha", 1.0, 0),
            ("metallic", 1.0, 0),
            ("roughness", 1.0, 0),
            ("emissive_strength", 100.0, imgui.SliderFlags_.logarithmic),
        ):
            label = field.replace("_", " ")
            changed, value = imgui.slider_float(label, float(now(field)), 0.0, high, flags=flags)
            if changed:
                self._edit(f"{key}.{field}", float(value))
        if given is not None and imgui.button("the file's values"):
            self._edit(key, None)

    def _material_editor(self, name: str) -> None:
        v = self.viewer
        key = f"materials.{name}"
        material = v.scene.materials[name]
        resolved = material.resolve()
        imgui.text(name)
        imgui.set_next_item_width(-1)
        _, self.preset_filter = imgui.input_text_with_hint(
            "##presets", "search presets", self.preset_filter
        )
        current = material.preset or "(none)"
        if imgui.begin_combo("preset", current):
            if imgui.selectable("(none)", material.preset is None)[0]:
                self._edit(f"{key}.preset", None)
            for preset in PRESETS:
                if (
                    self.preset_filter.lower() in preset.lower()
                    and imgui.selectable(preset, preset == material.preset)[0]
                ):
                    self._edit(f"{key}.preset", preset)
            imgui.end_combo()
        changed, color = imgui.color_edit3("base colour", list(resolved.base_color))
        if changed:
            self._edit(f"{key}.base_color", [float(c) for c in color])
        for field, low, high in (
            ("metallic", 0.0, 1.0),
            ("roughness", 0.0, 1.0),
            ("anisotropy", -1.0, 1.0),
        ):
            changed, value = imgui.slider_float(field, float(getattr(resolved, field)), low, high)
            if changed:
                self._edit(f"{key}.{field}", float(value))
        # F0 or the index of refraction (RTR4 §9.5): a scene gives one or the other.
        if material.ior is None:
            changed, value = imgui.slider_float("f0 (dielectric)", float(resolved.f0), 0.0, 1.0)
            if changed:
                self._edit(f"{key}.f0", float(value))
        if material.f0 is None:
            ior = resolved.params.eta_dielectric * (material.medium_ior or 1.0)
            changed, value = imgui.slider_float("index of refraction", float(ior), 1.0, 3.0)
            if changed:
                self._edit(f"{key}.ior", float(value))
        medium = material.medium_ior or 1.0
        changed, value = imgui.slider_float("medium index", float(medium), 1.0, 3.0)
        if changed:
            self._edit(f"{key}.medium_ior", float(value))
        imgui.separator()
        for field, names in (
            ("fresnel", FRESNEL_MODELS),
            ("ndf", NDF_MODELS),
            ("lambda_form", LAMBDA_FORMS),
            ("g2", G2_MODELS),
            ("correlation", CORRELATIONS),
            ("diffuse", DIFFUSE_MODELS),
        ):
            now = getattr(material, field)
            changed, index = imgui.combo(field, names.index(now), list(names))
            if changed and field == "diffuse":
                self.viewer.edit(diffuse_edit(key, now, names[index]))
            elif changed:
                self._edit(f"{key}.{field}", names[index])
        changed, on = imgui.checkbox("multiple scattering", material.multiscatter)
        if changed:
            self._edit(f"{key}.multiscatter", on)
        if material.ndf == "gtr":
            c = _control("gtr_gamma")
            changed, value = imgui.slider_float(c.label, resolved.params.gtr_gamma, c.low, c.high)
            if changed:
                self._edit(f"{key}.gtr_gamma", float(value))
        if material.fresnel == "schlick_generalized":
            self._field_color(key, material, "f90")
            p = 1.0 / resolved.params.fresnel_exponent
            c = _control("fresnel_p")
            changed, value = imgui.slider_float(c.label, p, c.low, c.high)
            if changed:
                self._edit(f"{key}.fresnel_p", float(value))
        if material.fresnel == "conductor":
            medium = material.medium_ior or 1.0
            for field, values, top in (
                ("eta", resolved.params.eta * medium, 10.0),
                ("k", resolved.params.k * medium, 10.0),
            ):
                changed, rgb = imgui.drag_float3(f"{field} (R, G, B)", [float(x) for x in values],
                                                 0.01, 0.0, top)  # fmt: skip
                if changed:
                    self._edit(f"{key}.{field}", [max(float(x), 1e-3) for x in rgb])
        if self._section("fibres (micro-cylinders)"):
            self._fibers(key, material)
        if material.diffuse == "cloth_empirical" and self._section("empirical cloth"):
            self._cloth_empirical(key, material)
        if self._section("layers: sheen, clear coat, thin film, grating"):
            self._layers(key, material)
        if self._section("maps and blend"):
            # Paths relative to the scene file; Enter applies, an empty path removes the
            # map. A missing or unreadable file is refused with the CLI's message.
            enter = imgui.InputTextFlags_.enter_returns_true
            for k in TEXTURE_KEYS:
                text = getattr(material, k) or ""
                entered, text = imgui.input_text(k, text, enter)
                if entered:
                    self._edit(f"{key}.{k}", text or None)
            if material.blend is not None:
                b = material.blend
                imgui.text_wrapped(f"blend: {b.material} through {b.mask}")
                changed, value = imgui.slider_float("blend threshold", b.threshold, 0.0, 1.0)
                if changed:
                    self._edit(f"{key}.blend.threshold", float(value))
                changed, value = imgui.slider_float("blend softness", b.softness, 0.0, 1.0)
                if changed:
                    self._edit(f"{key}.blend.softness", float(value))

    def _fibers(self, key: str, material: Any) -> None:
        """The micro-cylinder models of RTR4 §9.10 (a thread along the tangent); the scene
        format refuses the keys that choose or layer over the lobes a fibre replaces, and
        the refusal shows in the Problems panel."""
        now = FIBER_MODELS.index(material.fiber)
        changed, i = imgui.combo("fibre model", now, list(FIBER_MODELS))
        if changed:
            self.viewer.edit(fiber_edit(key, material.fiber, FIBER_MODELS[i]))
        if material.fiber == "none":
            return
        for name in FIBER_KEYS:
            if name not in SADEGHI_KEYS or material.fiber == "sadeghi":
                self._field_slider(key, material, name)

    def _cloth_empirical(self, key: str, material: Any) -> None:
        """The empirical cloth terms of RTR4 §9.10 (diffuse = "cloth_empirical"); unset keys
        show their defaults, which make the model Lambert."""
        for field, label in (("cloth_rim", "rim"), ("cloth_inner", "inner")):
            k, a = getattr(material, field) or (0.0, 1.0)
            changed, value = imgui.slider_float(f"k {label}", float(k), 0.0, 10.0)
            if changed:
                self._edit(f"{key}.{field}", [float(value), float(a)])
            changed, value = imgui.slider_float(f"{label} exponent", float(a), 0.01, 64.0)
            if changed:
                self._edit(f"{key}.{field}", [float(k), float(value)])
        for name in ("cloth_diffuse", "cloth_wrap", "cloth_sheen"):
            self._field_slider(key, material, name)
        # the wrapped cosine: Filament's (conserves energy) or the book's (RTR4 §9.10)
        now = CLOTH_WRAP_FORMS.index(material.cloth_wrap_form or "filament")
        changed, i = imgui.combo("wrap form", now, list(CLOTH_WRAP_FORMS))
        if changed:
            self._edit(f"{key}.cloth_wrap_form", CLOTH_WRAP_FORMS[i])
        for name in ("cloth_scatter", "cloth_sheen_color"):
            self._field_color(key, material, name)

    def _layers(self, key: str, material: Any) -> None:
        """The layers over the base (RTR4 §9.10-9.12). Turning one off removes its keys,
        which the scene format refuses without the layer."""
        sheen_on = material.sheen_color is not None and any(material.sheen_color)
        changed, on = imgui.checkbox("sheen (cloth)", sheen_on)
        if changed:
            self.viewer.edit(
                {f"{key}.sheen_color": [0.5, 0.5, 0.5]}
                if on
                else {f"{key}.sheen_color": None, f"{key}.sheen_roughness": None}
            )
        if sheen_on:
            names = [n for n in SHEEN_MODELS if n != "none"]
            now = names.index(material.sheen) if material.sheen in names else 0
            changed, i = imgui.combo("sheen NDF", now, names)
            if changed:
                self._edit(f"{key}.sheen", names[i])
            self._field_color(key, material, "sheen_color")
            self._field_slider(key, material, "sheen_roughness")
        c = _control("clearcoat")
        changed, value = imgui.slider_float(c.label, material.clearcoat, c.low, c.high)
        if changed:
            off = {f"{key}.clearcoat_{k}": None for k in ("roughness", "ior", "color")}
            self.viewer.edit({f"{key}.clearcoat": float(value), **(off if value <= 0.0 else {})})
        if material.clearcoat > 0.0:
            for name in ("clearcoat_roughness", "clearcoat_ior"):
                self._field_slider(key, material, name)
            self._field_color(key, material, "clearcoat_color")
            names = [n for n in CLEARCOAT_MODELS if n != "none"]
            now = names.index(material.clearcoat_model)
            changed, i = imgui.combo("coat model", now, names)
            if changed:
                self._edit(f"{key}.clearcoat_model", names[i])
        changed, on = imgui.checkbox("thin film", material.thin_film)
        if changed:
            self.viewer.edit(
                {f"{key}.thin_film": True}
                if on
                else {f"{key}.thin_film": None, f"{key}.film_thickness": None,
                      f"{key}.film_ior": None}
            )  # fmt: skip
        if material.thin_film:
            for name in ("film_thickness", "film_ior"):
                self._field_slider(key, material, name)
        # A grating's orders (RTR4 §9.11) move the isotropic GGX lobe: the scene format
        # refuses other bases, and the refusal shows in the Problems panel.
        changed, on = imgui.checkbox("diffraction grating", material.diffraction == "grating")
        if changed:
            self.viewer.edit(grating_edit(key, on))
        if material.diffraction == "grating":
            for name in ("grating_period", "grating_depth"):
                self._field_slider(key, material, name)
        # Transmission and volume (RTR4 §14.5, docs/transmission.md): glass drawn by the
        # transmission pass once transmission is above 0; the volume's keys beside it.
        self._field_slider(key, material, "transmission")
        if (material.transmission or 0.0) > 0.0:
            for name in ("thickness", "attenuation_distance", "dispersion"):
                self._field_slider(key, material, name)
            self._field_color(key, material, "attenuation_color")

    def _lights_panel(self) -> None:
        v = self.viewer
        if self._window("Lights"):
            # The scene's own lights; a glTF file's (import_lights) follow them and are
            # edited in the file (docs/gltf-lights-cameras.md).
            own = len(v.document.data.get("lights", []))
            if len(v.scene.lights) > own:
                imgui.text_wrapped(
                    f"+{len(v.scene.lights) - own} lights from glTF files (not editable)"
                )
            for i, light in enumerate(v.scene.lights[:own]):
                imgui.push_id(f"light{i}")
                if imgui.collapsing_header(f"{i}: {light.type}"):
                    key = f"lights[{i}]"
                    changed, color = imgui.color_edit3("colour", list(light.color))
                    if changed:
                        self._edit(f"{key}.color", [float(c) for c in color])
                    changed, value = imgui.slider_float(
                        "intensity",
                        light.intensity,
                        0.0,
                        100.0,
                        "%.3f",
                        imgui.SliderFlags_.logarithmic,
                    )
                    if changed:
                        self._edit(f"{key}.intensity", float(value))
                    if light.position is not None:
                        changed, p = imgui.drag_float3("position", list(light.position), 0.02)
                        if changed:
                            self._edit(f"{key}.position", [float(x) for x in p])
                    if light.direction is not None:
                        changed, d = imgui.drag_float3("direction", list(light.direction), 0.01)
                        if changed and np.linalg.norm(d) > 1e-6:
                            self._edit(f"{key}.direction", [float(x) for x in d])
                    if light.type != "directional":
                        changed, value = imgui.slider_float(
                            "range", light.effective_range, 0.05, 100.0
                        )
                        if changed:
                            self._edit(f"{key}.range", float(value))
                    if light.type == "spot":
                        inner, outer = light.cone
                        changed, value = imgui.slider_float("outer angle", outer, 1.0, 90.0)
                        if changed:
                            self._edit(f"{key}.outer_angle", float(value))
                            if inner >= value:
                                self._edit(f"{key}.inner_angle", float(value) * 0.8)
                        changed, value = imgui.slider_float("inner angle", inner, 0.0, outer - 0.01)
                        if changed:
                            self._edit(f"{key}.inner_angle", float(value))
                    self._area_light_controls(key, light)
                    if imgui.button("remove"):
                        self.viewer.remove_light(i)
                imgui.pop_id()
            imgui.separator()
            clicked = self._buttons("+ directional", "+ point", "+ spot")
            if clicked is not None:
                self.viewer.add_light(clicked[2:])
            # area lights (docs/area_lights.md): shaded by linearly transformed cosines
            clicked = self._buttons("+ rect", "+ disk", "+ sphere", "+ tube")
            if clicked is not None:
                self.viewer.add_light(clicked[2:])
        self._end()

    def _area_light_controls(self, key: str, light: Any) -> None:
        """An area light's size (docs/area_lights.md): a rectangle's width and height, a
        disk's, sphere's or tube's radius, a tube's length, in metres."""
        if light.size is not None:
            changed, size = imgui.drag_float2("size (m)", list(light.size), 0.01, 0.01, 20.0)
            if changed and min(size) > 0.0:
                self._edit(f"{key}.size", [float(x) for x in size])
        if light.radius is not None:
            changed, value = imgui.slider_float(
                "radius (m)", light.radius, 0.005, 5.0, "%.3f", imgui.SliderFlags_.logarithmic
            )
            if changed and value > 0.0:
                self._edit(f"{key}.radius", float(value))
        if light.length is not None:
            changed, value = imgui.slider_float("length (m)", light.length, 0.01, 20.0)
            if changed and value > 0.0:
                self._edit(f"{key}.length", float(value))

    def _render_panel(self) -> None:
        v = self.viewer
        s, cam = v.scene.render, v.scene.camera
        if self._window("Render"):
            changed, i = imgui.combo("tone map", TONEMAPS.index(s.tonemap), list(TONEMAPS))
            if changed:
                self._edit("render.tonemap", TONEMAPS[i])
            changed, value = imgui.slider_float("exposure (EV)", cam.exposure, -8.0, 8.0)
            if changed:
                self._edit("camera.exposure", float(value))
            changed, value = imgui.slider_float("field of view", cam.fov_y, 5.0, 120.0)
            if changed:
                self._edit("camera.fov_y", float(value))
            changed, value = imgui.slider_float("aperture (m)", cam.aperture, 0.0, 0.5)
            if changed:
                self._edit("camera.aperture", float(value))
            changed, value = imgui.slider_float("focus distance", cam.focus, 0.1, 100.0)
            if changed:
                self._edit("camera.focus_distance", float(value))
            for field, names in (
                ("gbuffer", ENCODING_NAMES),
                ("normal_filter", ("none", "naive", "toksvig", "variance", "lean", "auto")),
                ("terms", ("all", "specular", "diffuse")),
                ("blend", ("runtime", "baked")),
                ("light_culling", ("auto", "tiled", "none")),
                ("background", BACKGROUNDS),
            ):
                now = getattr(s, field)
                changed, i = imgui.combo(field, names.index(now), list(names))
                if changed:
                    self._edit(f"render.{field}", names[i])
            changed, on = imgui.checkbox("specular AA", s.specular_aa)
            if changed:
                self._edit("render.specular_aa", on)
            changed, n = imgui.slider_int("supersample", s.supersample, 1, 4)
            if changed:
                self._edit("render.supersample", int(n))
            views = ["(the render)", *DEBUG_VIEWS]
            now = views.index(v.debug_view) if v.debug_view else 0
            changed, i = imgui.combo("debug view", now, views)
            if changed:
                v.set_debug_view(None if i == 0 else views[i], v.debug_light)
            if v.debug_view in LIGHT_VIEWS:
                count = len(v.renderer.lights)
                changed, n = imgui.slider_int("of light", v.debug_light, 0, max(count - 1, 0))
                if changed:
                    v.set_debug_view(v.debug_view, n)
            changed, on = imgui.checkbox("vsync", v.vsync)
            if changed:
                v.set_vsync(on)
        self._end()

    def _plots_panel(self) -> None:
        v = self.viewer
        if self._window("Plots"):
            name = v.selection.material
            if name is not None and name in v.scene.materials:
                self._material_plots(name)
            _, self.timing = imgui.checkbox("time each pass", self.timing)
            times = v.state.frame_ms
            if (
                self.timing
                and times
                and implot.begin_plot("frame time (ms)", imgui.ImVec2(-1, 120))
            ):
                names = list(times)
                implot.setup_axis_ticks(
                    implot.ImAxis_.x1, list(map(float, range(len(names)))), names
                )
                implot.plot_bars("ms", np.array(list(times.values()), np.float64))
                implot.end_plot()
        self._end()

    def _material_plots(self, name: str) -> None:
        from app.brdf.plot import NamedMaterial, albedo_curve, lobes

        v = self.viewer
        definition = v.scene.materials[name]
        if self._curves is None or self._curves[0] != (name, definition):
            material = NamedMaterial(name, name, definition.resolve())
            try:
                curves = (lobes(material, LOBE_ANGLES, gl=v.gl), albedo_curve(material, gl=v.gl))
            except Exception as exc:  # a model the probe cannot evaluate: say so, keep going
                v.state.error = f"plots: {exc}"
                curves = None
            self._curves = ((name, definition), curves)
        curves = self._curves[1]
        if curves is None:
            return
        lobe_list, albedo = curves
        # Polar lobes in the plane of incidence, the normal up, equal axes so that the
        # lobe's direction reads true (pbs brdf's left panel).
        if implot.begin_plot(
            "f cos (plane of incidence)", imgui.ImVec2(-1, 170), implot.Flags_.equal
        ):
            for lobe in lobe_list:
                theta = np.radians(lobe.theta_v)
                value = lobe.value @ np.array([0.2126, 0.7152, 0.0722])
                implot.plot_line(
                    f"{lobe.theta_i:g} deg", value * np.sin(theta), value * np.cos(theta)
                )
            implot.end_plot()
        if implot.begin_plot("directional albedo", imgui.ImVec2(-1, 120)):
            implot.plot_line("R(theta)", np.asarray(albedo.theta, np.float64),
                             np.asarray(albedo.luminance, np.float64))  # fmt: skip
            implot.end_plot()

    def _compare_presets(self) -> list[tuple[str, str, str, str]]:
        """(label, key, A, B) of the comparisons a lesson reaches for first, for the
        selected material where one is selected."""
        out = [("normal filter: naive | variance", "render.normal_filter", '"naive"', '"variance"')]
        name = self.viewer.selection.material
        if name is not None and name in self.viewer.scene.materials:
            key = f"materials.{name}"
            metal = self.viewer.scene.materials[name].resolve().metallic >= 1.0
            exact = '"conductor"' if metal else '"dielectric"'
            out = [
                ("Fresnel: Schlick | exact", f"{key}.fresnel", '"schlick"', exact),
                ("G2: separable | height-corr.", f"{key}.g2", '"separable"', '"height_correlated"'),
                ("multiple scattering: off | on", f"{key}.multiscatter", "false", "true"),
                *out,
            ]
        return out

    def _compare_panel(self) -> None:
        v = self.viewer
        if self._window("Compare"):
            presets = self._compare_presets()
            clicked = self._buttons(*(p[0] for p in presets), small=True)
            for label, key, a, b in presets:
                if clicked == label:
                    self.compare_key, self.compare_a, self.compare_b = key, a, b
            _, self.compare_key = imgui.input_text("key", self.compare_key)
            _, self.compare_a = imgui.input_text("A (left)", self.compare_a)
            _, self.compare_b = imgui.input_text("B (right)", self.compare_b)
            changed, self.compare_mode = imgui.combo("view", self.compare_mode, list(VIEWS))
            mode = VIEWS[self.compare_mode]
            if changed and v.comparison is not None:
                v.compare_mode = mode
                v.state.dirty = True
            if imgui.button("Compare"):
                try:
                    a = parse_toml(f"v = {self.compare_a}", Limits().max_nesting)["v"]
                    b = parse_toml(f"v = {self.compare_b}", Limits().max_nesting)["v"]
                except (RefusedError, KeyError) as exc:
                    v.state.error = f"compare: A and B are TOML values (strings in quotes): {exc}"
                else:
                    v.compare(self.compare_key, a, b, mode, v.divider, v.gain)
            if v.comparison is not None:
                imgui.same_line()
                if imgui.button("Stop"):
                    v.stop_compare()
                changed, value = imgui.slider_float("divider", v.divider, 0.0, 1.0)
                if changed:
                    v.touch()
                    v.set_divider(value)
                log = imgui.SliderFlags_.logarithmic
                changed, value = imgui.slider_float("gain", v.gain, 1.0, 64.0, "%.1f", log)
                if changed:
                    v.gain = float(value)
                    v.state.dirty = True
        self._end()

    def _problems_panel(self) -> None:
        v = self.viewer
        if self._window("Problems"):
            if v.state.notice:
                imgui.text_colored(AMBER, v.state.notice)
            if v.state.error:
                imgui.text_colored(RED, "The last good state keeps running:")
                imgui.text_wrapped(v.state.error)
            elif not v.state.notice:
                imgui.text_disabled("No problems.")
        self._end()
