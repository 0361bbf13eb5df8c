"""The classroom walkthrough in the viewer (``pbs view --walkthrough``, docs/walkthrough.md).

``Lesson`` is the walkthrough's state and its actions, with no drawing, so a script or a
test drives what the panel's buttons do: go to a step (previous / next), open one of the
step's views, start one of its comparisons as the split screen (``Viewer.compare``), set
a sweep's value through ``Viewer.edit`` or play it back and forth, reset the step.

``LessonPanel`` draws the "Walkthrough" panel with Dear ImGui: the step's section and
title, its text (the Markdown subset laid out word by word, inline math as images), its
equations, and the lists of views, comparisons and sweeps. ImGui draws no LaTeX, so each
formula is rasterised by matplotlib's mathtext (``latex_to_rgba``), uploaded as a
texture in the viewer's GL context and drawn with ``add_image``; ``MathTextures`` caches
them per (LaTeX, size) and releases them all when the step changes or the viewer closes.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import moderngl
import numpy as np
from imgui_bundle import imgui

from app.walkthrough.markup import blocks, spans
from app.walkthrough.mathsvg import latex_to_rgba
from app.walkthrough.model import LoadedStep, Plot, Sweep, Text, resolve_scene_ref
from app.walkthrough.questions import formatted

if TYPE_CHECKING:
    from app.viewer.host import ViewerHost

PLAY_PERIOD = 4.0  # seconds for a played sweep to go from its start to its end and back
INLINE_SCALE = 1.1  # inline math's font size, relative to the panel's text
EQUATION_SCALE = 1.6  # a step's displayed equations, relative to the panel's text
TEXT_ASCENT = 0.8  # ImGui's default font: the baseline sits at 0.8 of the font size
CODE_COLOR = imgui.ImVec4(0.55, 0.85, 1.0, 1.0)
HEADING = {"en": "RTR4 §9.{}", "ko": "RTR4 §9.{}"}
UI = {  # the panel's own words
    "previous": {"en": "< previous", "ko": "< 이전"},
    "next": {"en": "next >", "ko": "다음 >"},
    "reset": {"en": "reset this step", "ko": "이 단계 처음으로"},
    "equations": {"en": "Equations", "ko": "수식"},
    "views": {"en": "Scenes (click: open)", "ko": "장면 (클릭: 열기)"},
    "comparisons": {"en": "A/B comparisons (click: split screen)",
                    "ko": "A/B 비교 (클릭: 화면 분할)"},
    "sweeps": {"en": "Sweeps (select, then drag or play)",
               "ko": "값 바꾸기 (선택 후 슬라이더 또는 재생)"},
    "plots": {"en": "Plots", "ko": "그래프"},
    "play": {"en": "play", "ko": "재생"},
    "questions": {"en": "Predict, then reveal", "ko": "예측하고 확인하기"},
    "reveal": {"en": "Reveal", "ko": "정답 보기"},
    "hide": {"en": "Hide", "ko": "숨기기"},
    "answer": {"en": "Answer", "ko": "정답"},
    "open view": {"en": "show the view", "ko": "그림 보기"},
    "stop": {"en": "stop comparing", "ko": "비교 끄기"},
}  # fmt: skip

# What each plot kind draws (app/walkthrough/model.py ``Plot``): ``pbs brdf``'s lobes, or
# a figure of app/brdf/figures.py, which only the handout draws (no command of its own).
PLOT_KINDS = {
    "lobes": {"en": "BRDF lobes and directional albedo", "ko": "BRDF 로브와 방향 알베도"},
    "vndf": {"en": "Visible-normal sampling (Heitz 2018) and the albedo estimators' variance",
             "ko": "가시 법선 샘플링 (Heitz 2018)과 알베도 추정의 분산"},
    "layered_furnace": {"en": "White furnace of the coated materials beside the random walk",
                        "ko": "코팅 재질의 화이트 퍼니스와 랜덤 워크"},
    "prefilter": {"en": "Environment prefilter: Monte Carlo at N samples against the exact "
                        "integral",
                  "ko": "환경 사전 필터링: N개 샘플의 몬테카를로 대 정확한 적분"},
}  # fmt: skip
PLOT_PARAMS = {
    "roughness": {"en": "roughness", "ko": "거칠기"},
    "theta": {"en": "view angles", "ko": "시선 각도"},
}


def plot_command(plot: Plot, section: int, lang: str) -> tuple[str, str]:
    """(what the plot shows, the command that draws it) in ``lang``: ``pbs brdf`` with its
    materials and angles for the lobes; for a figure of app/brdf/figures.py, its
    roughnesses (and view angles) and ``pbs walkthrough`` of the step, which draws it.
    Made once per plot and language (the panel asks every frame)."""
    theta = tuple(plot.theta) if plot.theta else ()
    return _plot_line(plot.kind, tuple(plot.materials), theta, section, lang)


@functools.lru_cache(maxsize=64)
def _plot_line(
    kind: str, materials: tuple[str, ...], theta: tuple[float, ...], section: int, lang: str
) -> tuple[str, str]:
    what = PLOT_KINDS[kind][lang]
    quoted = " ".join(f"'{m}'" for m in materials)
    if kind == "lobes":
        angles = f" --theta {','.join(f'{t:g}' for t in theta)}" if theta else ""
        return what, f"pbs brdf -o plot.png{angles} {quoted}"
    if kind in ("vndf", "prefilter"):
        from app.brdf.plot import parse_material_args

        rough = sorted({m.params.roughness for m in parse_material_args(materials)})
        what += f"; {PLOT_PARAMS['roughness'][lang]} {', '.join(f'{r:g}' for r in rough)}"
        if kind == "vndf" and theta:
            what += f"; {PLOT_PARAMS['theta'][lang]} {', '.join(f'{t:g}°' for t in theta)}"
    else:
        what += ": " + quoted
    return what, f"pbs walkthrough --out handout --steps {section}"


@dataclass
class MathImage:
    """A formula's texture, its size in pixels and its depth below the baseline."""

    texture: moderngl.Texture
    width: int
    height: int
    depth: float

    @property
    def ref(self) -> imgui.ImTextureRef:
        return imgui.ImTextureRef(self.texture.glo)


class MathTextures:
    """Formula textures in one GL context, made on first use, cached per (LaTeX, size in
    pixels) and released together (``release``)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._cache: dict[tuple[str, int], MathImage] = {}

    def get(self, latex: str, size_px: int) -> MathImage:
        key = (latex, int(size_px))
        image = self._cache.get(key)
        if image is None:
            rgba, depth = latex_to_rgba(latex, float(size_px))
            h, w = rgba.shape[:2]
            # Rows top to bottom as ImGui's uv (0, 0) .. (1, 1) expects; straight alpha,
            # which ImGui's blend (src alpha, 1 - src alpha) takes.
            texture = self.ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes())
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            image = MathImage(texture, w, h, depth)
            self._cache[key] = image
        return image

    def __len__(self) -> int:
        return len(self._cache)

    def images(self) -> list[MathImage]:
        return list(self._cache.values())

    def release(self) -> None:
        for image in self._cache.values():
            image.texture.release()
        self._cache.clear()


class Lesson:
    """The walkthrough's steps, the step shown, the language and the selected sweep."""

    def __init__(self, viewer: ViewerHost, steps: list[LoadedStep], lang: str = "en") -> None:
        if not steps:
            raise ValueError("a lesson needs at least one step")
        self.viewer = viewer
        self.steps = steps
        self.lang = lang
        self.index = 0
        self.scene_ref: str | None = None  # the step's scene shown now
        self.sweep: int | None = None  # the selected sweep of the step
        self.sweep_value = 0.0
        self.playing = False
        self._play_start = 0.0
        self.math = MathTextures(viewer.ctx)
        self.revealed: set[int] = set()  # the step's questions whose answer is shown
        self.focus: int | None = None  # a question the panel scrolls to when next drawn

    @property
    def current(self) -> LoadedStep:
        return self.steps[self.index]

    def text(self, text: Text | None) -> str:
        return "" if text is None else text.get(self.lang)  # type: ignore[arg-type]

    def scene_refs(self) -> list[str]:
        """The step's scenes in the order it names them (views, comparisons, sweeps)."""
        step = self.current.step
        refs = [item.scene for kind in (step.views, step.comparisons, step.sweeps)
                for item in kind]  # fmt: skip
        return list(dict.fromkeys(refs))

    def go(self, index: int) -> bool:
        """Show step ``index`` (0-based, clamped): its first scene from its file, no
        comparison, no sweep; the last step's formula textures are released."""
        self.index = int(np.clip(index, 0, len(self.steps) - 1))
        self.math.release()
        self.revealed, self.focus = set(), None
        self.sweep, self.playing = None, False
        refs = self.scene_refs()
        if not refs:  # a step of plots only: the scene shown stays
            self.viewer.stop_compare()
            self.scene_ref = None
            return True
        return self.open(refs[0], fresh=True)

    def go_section(self, section: int) -> bool:
        """Show the step of RTR4 §9.``section``."""
        for i, loaded in enumerate(self.steps):
            if loaded.step.section == section:
                return self.go(i)
        raise ValueError(f"no step for section {section}")

    def next(self) -> bool:
        return self.go(self.index + 1)

    def previous(self) -> bool:
        return self.go(self.index - 1)

    def path(self, ref: str) -> Path:
        return resolve_scene_ref(ref, self.current.path).resolve()

    def open(self, ref: str, fresh: bool = False) -> bool:
        """Show the step's scene ``ref``: from its file when ``fresh`` or when another
        scene is shown (a comparison of the last scene stops either way)."""
        v = self.viewer
        self.playing = False
        if not fresh and v.document.path == self.path(ref):
            v.stop_compare()
            self.scene_ref = ref
            return True
        v.stop_compare()
        if not v.open_scene(self.path(ref)):
            return False
        # Projector-ready framing (``pbs render --fit``) is the window's own: it shows
        # every scene fitted to the image area (``Viewer.display_scene``), so the step's
        # scene keeps its file's fov_y here.
        self.scene_ref = ref
        return True

    def open_view(self, i: int) -> bool:
        self.sweep = None
        return self.open(self.current.step.views[i].scene, fresh=True)

    def compare(self, i: int) -> bool:
        """Comparison ``i`` of the step in the split screen: its scene (as the step file
        names it, edits kept if it is already shown) with A on the left, B on the right,
        the divider on the object the two differ on most (a material's object, a spot
        light's pool, a floor's glint), wherever the image area puts it."""
        c = self.current.step.comparisons[i]
        if not self.open(c.scene):
            return False
        return self.viewer.compare(c.key, c.a, c.b, divider=None)

    def select_sweep(self, i: int) -> bool:
        """Select sweep ``i``: its scene shown, the slider at the sweep's start value."""
        sweep = self.current.step.sweeps[i]
        if not self.open(sweep.scene):
            return False
        self.sweep = i
        return self.set_sweep(sweep.start)

    def sweep_item(self) -> Sweep | None:
        return None if self.sweep is None else self.current.step.sweeps[self.sweep]

    def set_sweep(self, value: float) -> bool:
        """Every key of the selected sweep set to ``value`` (a live edit)."""
        sweep = self.sweep_item()
        if sweep is None:
            return False
        self.sweep_value = float(value)
        return self.viewer.edit({key: float(value) for key in sweep.keys})

    def play(self, on: bool) -> None:
        """Animate the selected sweep from its start to its end and back (``tick``)."""
        self.playing = bool(on) and self.sweep is not None
        sweep = self.sweep_item()
        if self.playing and sweep is not None:
            span = sweep.to - sweep.start
            phase = 0.0 if span == 0 else (self.sweep_value - sweep.start) / span
            self._play_start = time.perf_counter() - 0.5 * PLAY_PERIOD * float(np.clip(phase, 0, 1))

    def tick(self) -> None:
        """One frame of a played sweep: a triangle wave between ``from`` and ``to``."""
        sweep = self.sweep_item()
        if not self.playing or sweep is None:
            return
        t = ((time.perf_counter() - self._play_start) / PLAY_PERIOD) % 1.0
        phase = 2.0 * t if t < 0.5 else 2.0 - 2.0 * t
        self.set_sweep(sweep.start + (sweep.to - sweep.start) * phase)

    def reveal(self, i: int, shown: bool = True) -> bool:
        """Show (or hide) question ``i``'s answer: its numbers computed by the twins (the
        first time), and its view opened, as the handout's "Reveal" shows them."""
        question = self.current.step.questions[i]
        if not shown:
            self.revealed.discard(i)
            return True
        self.revealed.add(i)
        formatted(question.numbers)  # computed now, not while the panel draws
        if question.view is not None:
            return self.open_view(question.view)
        return True

    def answer(self, i: int) -> str:
        """Question ``i``'s answer in the lesson's language: the right choice's letter and
        the text with its computed numbers."""
        question = self.current.step.questions[i]
        head = UI["answer"][self.lang]
        if question.correct is not None:
            head += f" {'ABCD'[question.correct]}"
        text = question.answer_text(self.lang, formatted(question.numbers))  # type: ignore[arg-type]
        return f"**{head}.** {text}"

    def reset(self) -> bool:
        """The step's scene shown now, again from its file: edits, comparison and sweep
        dropped."""
        self.sweep, self.playing = None, False
        refs = self.scene_refs()
        ref = self.scene_ref if self.scene_ref in refs else (refs[0] if refs else None)
        if ref is None:
            return True
        return self.open(ref, fresh=True)

    def close(self) -> None:
        self.math.release()


def wrap_label(text: str, width: float) -> str:
    """``text`` with line breaks where its words would pass ``width`` pixels (ImGui's
    buttons and radio buttons do not wrap their labels: a long one would be cut at the
    panel's edge). A single word wider than ``width`` keeps its own line."""
    lines: list[str] = []
    for word in text.split(" "):
        if lines and imgui.calc_text_size(f"{lines[-1]} {word}").x <= width:
            lines[-1] = f"{lines[-1]} {word}"
        else:
            lines.append(word)
    return "\n".join(lines)


def _ui(word: str, lang: str) -> str:
    return UI[word][lang]


class LessonPanel:
    """Draws a ``Lesson`` as the "Walkthrough" panel. Remembers where it drew the title
    and each equation (screen pixels, for the tests that read the window there)."""

    def __init__(self) -> None:
        self.title_rect: tuple[float, float, float, float] | None = None
        self.equation_rects: list[tuple[float, float, float, float]] = []
        self.window_rect: tuple[float, float, float, float] | None = None
        self.title_font: Any = None  # None: the panel's font (a test swaps it)
        self.show_plots = False  # True: the Plots header open, scrolled to (a script's)

    def draw(self, lesson: Lesson, panels: Any) -> None:
        lang = lesson.lang
        step = lesson.current.step
        if panels._window("Walkthrough"):
            pos, size = imgui.get_window_pos(), imgui.get_window_size()
            self.window_rect = (pos.x, pos.y, pos.x + size.x, pos.y + size.y)
            self._header(lesson, panels)
            imgui.separator()
            if self.title_font is not None:
                imgui.push_font(self.title_font, 0.0)
            imgui.text_wrapped(f"{HEADING[lang].format(step.section)} {step.title.get(lang)}")
            if self.title_font is not None:
                imgui.pop_font()
            lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
            self.title_rect = (lo.x, lo.y, hi.x, hi.y)
            imgui.spacing()
            self.flow(lesson, step.text.get(lang))
            self._equations(lesson)
            self._views(lesson)
            self._comparisons(lesson)
            self._sweeps(lesson)
            self._questions(lesson)
            if step.plots and self.show_plots:
                imgui.set_next_item_open(True)
            if step.plots and imgui.collapsing_header(_ui("plots", lang)):
                if self.show_plots:
                    imgui.set_scroll_here_y(0.0)
                for plot in step.plots:
                    what, command = plot_command(plot, step.section, lang)
                    imgui.text_wrapped(what)
                    self.flow(lesson, lesson.text(plot.caption))
                    imgui.text_colored(CODE_COLOR, command)
        panels._end()

    def _header(self, lesson: Lesson, panels: Any) -> None:
        lang = lesson.lang
        # "< previous  3 / 13  next >" (the count a disabled button: a label in the row)
        count = f"{lesson.index + 1} / {len(lesson.steps)}##count"
        clicked = panels._buttons(_ui("previous", lang), count, _ui("next", lang),
                                  _ui("reset", lang))  # fmt: skip
        if clicked == _ui("previous", lang):
            lesson.previous()
        elif clicked == _ui("next", lang):
            lesson.next()
        elif clicked == _ui("reset", lang):
            lesson.reset()
        if imgui.radio_button("EN", lang == "en"):
            lesson.lang = "en"
        imgui.same_line()
        # Without the Hangul font (not merged until Korean is asked for) the name in
        # Hangul would be boxes.
        korean = "한국어" if panels.hangul else "Korean"
        if imgui.radio_button(f"{korean}##ko", lang == "ko") and panels.load_hangul():
            lesson.lang = "ko"

    # --- text with inline math ------------------------------------------------------------

    def flow(self, lesson: Lesson, text: str) -> None:
        """``text`` (the Markdown subset) laid out word by word in the panel's width,
        inline math as images on the text's baseline."""
        for kind, items in blocks(text):
            for item in items:
                self._paragraph(lesson, item, bullet=kind == "ul")
            imgui.spacing()

    def _paragraph(self, lesson: Lesson, text: str, bullet: bool) -> None:
        font = imgui.get_font_size()
        space = imgui.calc_text_size(" ").x
        indent = imgui.calc_text_size("- ").x if bullet else 0.0
        width = max(imgui.get_content_region_avail().x - indent, 4 * font)
        # Tokens: (width, ascent, descent, a formula or (word, colour), spaced from the
        # token before it in the source).
        tokens: list[tuple[float, float, float, Any, bool]] = []
        spaced = False
        for kind, content in spans(text):
            if kind == "math":
                image = lesson.math.get(content, round(font * INLINE_SCALE))
                tokens.append((image.width, image.height - image.depth, image.depth, image,
                               spaced))  # fmt: skip
                spaced = False
                continue
            colour = CODE_COLOR if kind == "code" else None
            words = content.split(" ")
            for j, word in enumerate(words):
                if word:
                    tokens.append((imgui.calc_text_size(word).x, TEXT_ASCENT * font,
                                   (1 - TEXT_ASCENT) * font, (word, colour),
                                   spaced or j > 0))  # fmt: skip
                    spaced = False
            spaced = content.endswith(" ")
        lines: list[list[tuple[float, Any]]] = [[]]
        x = 0.0
        metrics: list[tuple[float, float]] = [(TEXT_ASCENT * font, (1 - TEXT_ASCENT) * font)]
        for w, ascent, descent, what, spaced in tokens:
            gap = space if lines[-1] and spaced else 0.0
            if lines[-1] and x + gap + w > width:
                lines.append([])
                metrics.append((TEXT_ASCENT * font, (1 - TEXT_ASCENT) * font))
                x, gap = 0.0, 0.0
            lines[-1].append((x + gap, what))
            x += gap + w
            a, d = metrics[-1]
            metrics[-1] = (max(a, ascent), max(d, descent))
        origin = imgui.get_cursor_screen_pos()
        draw = imgui.get_window_draw_list()
        text_colour = imgui.get_color_u32(imgui.Col_.text)
        y = origin.y
        if bullet:
            draw.add_text(imgui.ImVec2(origin.x, y + metrics[0][0] - TEXT_ASCENT * font),
                          text_colour, "-")  # fmt: skip
        for line, (ascent, descent) in zip(lines, metrics, strict=True):
            baseline = y + ascent
            for x, what in line:
                left = origin.x + indent + x
                if isinstance(what, MathImage):
                    top = baseline - (what.height - what.depth)
                    draw.add_image(what.ref, imgui.ImVec2(left, top),
                                   imgui.ImVec2(left + what.width, top + what.height))  # fmt: skip
                else:
                    word, colour = what
                    col = text_colour if colour is None else imgui.get_color_u32(colour)
                    draw.add_text(imgui.ImVec2(left, baseline - TEXT_ASCENT * font), col, word)
            y += ascent + descent + 2.0
        imgui.dummy(imgui.ImVec2(width + indent, y - origin.y))

    # --- the step's lists ---------------------------------------------------------------------

    def _equations(self, lesson: Lesson) -> None:
        step = lesson.current.step
        self.equation_rects = []
        if not _open_list(step.equations, "equations", lesson.lang):
            return
        size = round(imgui.get_font_size() * EQUATION_SCALE)
        avail = imgui.get_content_region_avail().x
        for equation in step.equations:
            image = lesson.math.get(equation.latex, size)
            scale = min(1.0, avail / max(image.width, 1))  # a wide one shrinks to fit
            imgui.image(image.ref, imgui.ImVec2(image.width * scale, image.height * scale))
            lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
            self.equation_rects.append((lo.x, lo.y, hi.x, hi.y))
            if equation.caption is not None:
                self.flow(lesson, lesson.text(equation.caption))

    def _views(self, lesson: Lesson) -> None:
        step = lesson.current.step
        if not _open_list(step.views, "views", lesson.lang):
            return
        for i, view in enumerate(step.views):
            imgui.push_id(f"view{i}")
            shown = lesson.viewer.comparison is None and lesson.scene_ref == view.scene
            if imgui.selectable(wrap_label(view.scene, imgui.get_content_region_avail().x),
                                shown)[0]:  # fmt: skip
                lesson.open_view(i)
            if view.caption is not None:
                imgui.indent()
                self.flow(lesson, lesson.text(view.caption))
                imgui.unindent()
            imgui.pop_id()

    def _comparisons(self, lesson: Lesson) -> None:
        step, lang = lesson.current.step, lesson.lang
        if not _open_list(step.comparisons, "comparisons", lesson.lang):
            return
        for i, c in enumerate(step.comparisons):
            imgui.push_id(f"comparison{i}")
            label = f"{c.label_a.get(lang)}  |  {c.label_b.get(lang)}"
            room = imgui.get_content_region_avail().x - 2 * imgui.get_style().frame_padding.x
            if imgui.button(wrap_label(label, room)):
                lesson.compare(i)
            imgui.push_style_color(
                imgui.Col_.text, imgui.get_style_color_vec4(imgui.Col_.text_disabled)
            )
            imgui.text_wrapped(f"{c.scene}: {c.key}")
            imgui.pop_style_color()
            if c.caption is not None:
                self.flow(lesson, lesson.text(c.caption))
            imgui.pop_id()
        if lesson.viewer.comparison is not None and imgui.button(_ui("stop", lang)):
            lesson.viewer.stop_compare()

    def _sweeps(self, lesson: Lesson) -> None:
        step, lang = lesson.current.step, lesson.lang
        if not _open_list(step.sweeps, "sweeps", lesson.lang):
            return
        for i, sweep in enumerate(step.sweeps):
            imgui.push_id(f"sweep{i}")
            label = ", ".join(sweep.keys)
            style = imgui.get_style()
            room = imgui.get_content_region_avail().x - imgui.get_frame_height()
            room -= style.item_inner_spacing.x
            if imgui.radio_button(wrap_label(f"{sweep.scene}: {label}", room), lesson.sweep == i):
                lesson.select_sweep(i)
            if sweep.caption is not None:
                self.flow(lesson, lesson.text(sweep.caption))
            if lesson.sweep == i:
                low, high = sorted((sweep.start, sweep.to))
                changed, value = imgui.slider_float(
                    "##value", lesson.sweep_value, low, high, "%.3f"
                )
                if changed:
                    lesson.playing = False
                    lesson.set_sweep(float(value))
                imgui.same_line()
                changed, on = imgui.checkbox(_ui("play", lang), lesson.playing)
                if changed:
                    lesson.play(on)
                imgui.text(sweep.value_text(lesson.sweep_value, lang))
            imgui.pop_id()

    def _questions(self, lesson: Lesson) -> None:
        step, lang = lesson.current.step, lesson.lang
        if not _open_list(step.questions, "questions", lang):
            return
        for i, question in enumerate(step.questions):
            imgui.push_id(f"question{i}")
            if lesson.focus == i:  # scrolled to the top of the panel once (Lesson.focus)
                imgui.set_scroll_here_y(0.0)
                lesson.focus = None
            self.flow(lesson, f"**Q{i + 1}.** {question.ask.get(lang)}")  # type: ignore[arg-type]
            for j, choice in enumerate(question.choices or []):
                self.flow(lesson, f"{'ABCD'[j]}. {choice.get(lang)}")  # type: ignore[arg-type]
            shown = i in lesson.revealed
            if imgui.button(_ui("hide" if shown else "reveal", lang)):
                lesson.reveal(i, not shown)
                shown = not shown
            if shown:
                if question.view is not None:
                    imgui.same_line()
                    if imgui.button(_ui("open view", lang)):
                        lesson.open_view(question.view)
                self.flow(lesson, lesson.answer(i))
            imgui.separator()
            imgui.pop_id()


def _open_list(items: list, word: str, lang: str) -> bool:
    """A list's collapsing header (open at first), drawn only when the step has items."""
    return bool(items) and imgui.collapsing_header(
        _ui(word, lang), imgui.TreeNodeFlags_.default_open
    )
