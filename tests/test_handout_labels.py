"""The handout's labels and captions: placed without overlap, never cut, and Korean on
the Korean handout.

Real components: the bundled step files of walkthrough/, the system's fonts (fc-match:
DejaVu Sans and Noto Sans CJK KR), a real EGL context for the views.
"""

from __future__ import annotations

import re
from itertools import combinations

import numpy as np
import pytest

from app.gl.context import GLContext
from app.walkthrough.build import (
    WORDS,
    image_size,
    label_texts,
    render_view,
    sweep_frame_size,
    sweep_label,
)
from app.walkthrough.labels import (
    Silhouette,
    band_layout,
    caption_band,
    find_font,
    font_size,
    place_labels,
)
from app.walkthrough.model import LoadedStep, load_step, load_walkthrough
from tests.conftest import REPO

STEPS = REPO / "walkthrough"
LANGS = ("en", "ko")
# The sizes the handout is made at: each scene's own (None), the screenshot's, a projector's.
SIZES = (None, (640, 360), (1920, 1080))


@pytest.fixture(scope="module")
def steps() -> list[LoadedStep]:
    """The 13 bundled steps, validated once for the module."""
    return load_walkthrough(STEPS)


def _overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


# --- placement ------------------------------------------------------------------------------


def test_clustered_objects_get_labels_that_do_not_overlap() -> None:
    """Seven spheres receding into the distance (the depth-of-field row: the far ones a
    few pixels apart) get seven labels, no two overlapping, all inside the image; a label
    moved away from its object has a leader line that ends on the object; the placement
    is the same every time."""
    face = find_font("en")
    shapes = {
        i: Silhouette(x - r, y - r, x + r, y + r)
        for i, (x, y, r) in enumerate(
            [(60, 300, 110), (220, 255, 80), (345, 215, 52), (415, 195, 36),
             (457, 182, 28), (485, 172, 22), (505, 165, 18)]
        )
    }  # fmt: skip
    texts = [(i, f"sphere {i + 1}, {3.0 + 2.2 * i:.1f} m") for i in shapes]
    placed, left_out = place_labels(texts, shapes, (960, 420), face, font_size(420))
    assert not left_out and len(placed) == 7
    for a, b in combinations(placed, 2):
        assert not _overlap(a.box, b.box), (a, b)
    for label in placed:
        left, top, right, bottom = label.box
        assert 0 <= left < right <= 960 and 0 <= top < bottom <= 420
    moved = [(i, p) for (i, _), p in zip(texts, placed, strict=True) if p.leader is not None]
    assert moved, "the far spheres' labels cannot all sit beside them"
    for index, label in moved:
        (x0, y0), (x1, y1) = label.leader
        shape = shapes[index]
        assert shape.left - 1 <= x1 <= shape.right + 1 and shape.top - 1 <= y1 <= shape.bottom + 1
        left, top, right, bottom = label.box
        assert left - 1 <= x0 <= right and top - 1 <= y0 <= bottom
    again, _ = place_labels(texts, shapes, (960, 420), face, font_size(420))
    assert again == placed


# --- every view of the lesson ---------------------------------------------------------------


def test_no_two_labels_overlap_in_any_view(gl_egl: GLContext, steps: list[LoadedStep]) -> None:
    """Every view of the 13 steps, at its scene's own size and the screenshot's 640x360,
    in both languages: every label is placed, inside the image, and no two labels' boxes
    overlap (the depth-of-field labels of step 2 piled onto each other before)."""
    problems = []
    for loaded in steps:
        for i, view in enumerate(loaded.step.views):
            scene = loaded.scene(view.scene)
            for size in SIZES[:2]:
                w, h = image_size(scene, size)
                for lang in LANGS:
                    where = f"{loaded.slug} views[{i}] {w}x{h} {lang}"
                    images = render_view(gl_egl, view, scene, size, lang)
                    if images.left_out:
                        problems.append(f"{where}: no place for objects {images.left_out}")
                    wanted = len(label_texts(view, scene, lang))
                    if len(images.labels) + len(images.left_out) != wanted:
                        problems.append(f"{where}: {len(images.labels)} of {wanted} labels")
                    for a, b in combinations(images.labels, 2):
                        if _overlap(a.box, b.box):
                            problems.append(f"{where}: {a.lines} overlaps {b.lines}")
                    for label in images.labels:
                        left, top, right, bottom = label.box
                        if min(left, top) < 0 or right > w or bottom > h:
                            problems.append(f"{where}: {label.lines} leaves the image")
    assert not problems, "\n".join(problems)


# --- captions under a sweep's frames and on a comparison's sides ------------------------------


@pytest.mark.parametrize("where", ["below", "top"])
def test_a_caption_wider_than_its_frame_wraps(where: str) -> None:
    """The sweep caption the handout cut, "medium_ior = medium_ior 1.000" under a frame
    120 pixels wide at 14-pixel text: broken into lines (or smaller) so that every light
    pixel of its text stays inside the frame."""
    face = find_font("en")
    frame = np.zeros((68, 120, 3), np.uint8)
    image = caption_band(frame, "medium_ior = medium_ior 1.000", face, 14, where)
    band = image[68:] if where == "below" else image
    ink = _ink_columns(band)
    assert ink.size and ink[0] >= 1 and ink[-1] <= 118, (ink.min(), ink.max())
    rows = np.flatnonzero((band.min(axis=2) > 150).any(axis=1))
    assert rows[-1] - rows[0] > 14, "one line of 14-pixel text cannot hold it: it must wrap"


def _ink_columns(band: np.ndarray) -> np.ndarray:
    """Columns of a band that hold light text pixels."""
    return np.flatnonzero((band.min(axis=2) > 150).any(axis=0))


@pytest.mark.parametrize("lang", LANGS)
def test_no_caption_is_cut_at_its_frame(lang: str, steps: list[LoadedStep]) -> None:
    """Every sweep's text under every frame, and every comparison side's label, of the 13
    steps at the handout's sizes: the text's light pixels keep clear of the frame's left
    and right edges (a caption wider than its frame, "medium_ior = medium_ior 1.000"
    under a 300-pixel frame, was cut at both), and a strip's bands are all one height."""
    face = find_font(lang)
    problems = []
    for loaded in steps:
        for i, sweep in enumerate(loaded.step.sweeps):
            scene = loaded.scene(sweep.scene)
            for size in SIZES:
                fw, fh = sweep_frame_size(image_size(scene, size), sweep.steps)
                texts = [sweep_label(sweep, v, lang) for v in sweep.values()]
                text_size, rows = band_layout(texts, face, font_size(fh, sweep.steps * fw), fw)
                heights = set()
                for text in texts:
                    frame = np.zeros((fh, fw, 3), np.uint8)
                    band = caption_band(frame, text, face, text_size, "below", rows)[fh:]
                    heights.add(band.shape[0])
                    ink = _ink_columns(band)
                    if ink.size == 0 or ink[0] < 1 or ink[-1] > fw - 2:
                        problems.append(f"{loaded.slug} sweeps[{i}] {fw}px: {text!r} is cut")
                if len(heights) != 1:
                    problems.append(f"{loaded.slug} sweeps[{i}]: bands of heights {heights}")
        for i, item in enumerate(loaded.step.comparisons):
            scene = loaded.scene(item.scene)
            for size in SIZES:
                w, h = image_size(scene, size)
                labels = (item.label_a.get(lang), item.label_b.get(lang), WORDS["difference"][lang])
                for text in labels:
                    side = np.zeros((h, w, 3), np.uint8)
                    ink = _ink_columns(caption_band(side, text, face, font_size(h, 3 * w)))
                    if ink.size == 0 or ink[-1] > w - 2:
                        problems.append(f"{loaded.slug} comparisons[{i}] {w}px: {text!r} is cut")
    assert not problems, "\n".join(problems)


# --- the Korean handout's labels --------------------------------------------------------------

# Latin words a Korean label may keep: symbols, units, and names the Korean text of the
# lesson also leaves in Latin letters (models and products known by them).
UNTRANSLATED = {
    "A", "B", "F0", "G2", "EV", "m", "nm", "GGX", "GTR1", "GTR3", "MgF2", "CD", "Schott",
    "K7", "Charlie", "Ashikhmin", "Kajiya-Kay", "Sadeghi", "Filament", "Weidlich-Wilkie",
    "RTR4",  # the book, cited by name in both languages (docs/walkthrough.md, glossary)
}  # fmt: skip
_LATIN_WORD = re.compile(r"[A-Za-z][A-Za-z0-9]*(?:-[A-Za-z0-9]+)*")


def _korean_labels(steps: list[LoadedStep]) -> list[tuple[str, str, str]]:
    """(where, English text, Korean text) of every label the handout draws on an image:
    the views' labels, the comparisons' sides and difference, the sweeps' values."""
    out = []
    for loaded in steps:
        step = loaded.step
        for i, view in enumerate(step.views):
            scene = loaded.scene(view.scene)
            en, ko = label_texts(view, scene, "en"), label_texts(view, scene, "ko")
            out += [(f"{loaded.slug} views[{i}]", en[k], ko[k]) for k in ko]
        for i, item in enumerate(step.comparisons):
            for side in (item.label_a, item.label_b):
                out.append((f"{loaded.slug} comparisons[{i}]", side.en, side.ko))
            out.append((f"{loaded.slug} comparisons[{i}]", *WORDS["difference"].values()))
        for i, sweep in enumerate(step.sweeps):
            for value in sweep.values():
                texts = (sweep_label(sweep, value, lang) for lang in LANGS)
                out.append((f"{loaded.slug} sweeps[{i}]", *texts))
    return out


def test_korean_labels_are_korean(steps: list[LoadedStep]) -> None:
    """Every label on the Korean handout's images is Korean: the Latin words it keeps are
    symbols, units and proper names (UNTRANSLATED); no object's English scene name, no
    English sweep value ("roughness = 0.50"). A label equal to its English text is made
    of those tokens and numbers alone."""
    labels = _korean_labels(steps)
    assert len(labels) > 250
    problems = []
    for where, en, ko in labels:
        foreign = [w for w in _LATIN_WORD.findall(ko) if w not in UNTRANSLATED]
        if foreign:
            problems.append(f"{where}: {ko!r} keeps {foreign}")
        elif ko == en and re.search("[가-힣]", ko):
            problems.append(f"{where}: {ko!r} is the same in English")
    assert not problems, f"{len(problems)} English labels:\n" + "\n".join(problems[:40])


# --- the sweep's label in the step format ------------------------------------------------------


def test_a_sweep_label_is_checked_in_both_languages(tmp_path) -> None:
    """``label`` formats the value in each language: one that formats no number is one
    error naming ``sweeps[0].label.ko``; ``label`` with ``format`` is refused."""
    from app.errors import InputError

    source = (STEPS / "06-microgeometry.toml").read_text(encoding="utf-8")
    assert 'ko = "거칠기 {:.2f}"' in source
    bad = tmp_path / "06-microgeometry.toml"
    bad.write_text(source.replace('ko = "거칠기 {:.2f}"', 'ko = "거칠기 {:.2d}"'), "utf-8")
    with pytest.raises(InputError) as caught:
        load_step(bad)
    assert caught.value.key == "sweeps[0].label.ko"
    both = source.replace('ko = "거칠기 {:.2f}" }', 'ko = "거칠기 {:.2f}" }\nformat = "{:.1f}"')
    bad.write_text(both, "utf-8")
    with pytest.raises(InputError) as caught:
        load_step(bad)
    assert caught.value.key.startswith("sweeps[0]")
    loaded = load_step(STEPS / "06-microgeometry.toml")
    sweep = loaded.step.sweeps[0]
    assert sweep.value_text(0.5, "ko") == "거칠기 0.50"
    assert sweep.value_text(0.5, "en") == "roughness 0.50"


# --- the BRDF plots' words ------------------------------------------------------------------

# Latin words a plot's text may keep besides UNTRANSLATED: the quantities' symbols and
# the names of code.
PLOT_TOKENS = {"f", "l", "v", "n", "i", "cos", "dv", "sr", "R", "G", "B", "RGB", "GLSL",
               "float64", "app", "brdf", "evaluate", "e", "R_8192", "R_2048"}  # fmt: skip


def _foreign_words(text: str) -> list[str]:
    words = re.findall(r"[A-Za-z][A-Za-z0-9_]*", text.replace("e-", " "))
    return [w for w in words if w not in UNTRANSLATED | PLOT_TOKENS]


def _figure_texts(lang: str) -> list[str]:
    """Every text the handout's BRDF figure draws in ``lang``, but the materials' names
    and models (the plot's input, as written in the step file: `standard`, `dielectric
    + none`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    from app.brdf import plot as brdf_plot
    from app.walkthrough.build import figure_words

    material = brdf_plot.parse_material_args(['{ ndf = "ggx", roughness = 0.3 }'])
    columns = brdf_plot.compute_columns(material, (30.0,), "fcos", "reference")
    figure = brdf_plot.render_figure(
        columns, "fcos", dpi=40, backend="reference", words=figure_words(lang)
    )
    FigureCanvasAgg(figure).draw()
    name = material[0].name
    texts = [t.get_text() for t in figure.findobj(Text) if t.get_text().strip()]
    return [t.split("\n", 1)[1].split(", ", 1)[1] if t.startswith(name) else t for t in texts]


def test_the_korean_plots_words_are_korean() -> None:
    """The BRDF figure on the Korean handout (``pbs brdf``'s, its words given by the
    walkthrough): its title, axis names, legend and notes are Korean; the same check
    finds the English figure's words (it can fail)."""
    korean = _figure_texts("ko")
    assert any(re.search("[가-힣]", t) for t in korean)
    foreign = [(t, _foreign_words(t)) for t in korean if _foreign_words(t)]
    assert not foreign, foreign
    english = [t for t in _figure_texts("en") if _foreign_words(t)]
    assert len(english) >= 5, english
