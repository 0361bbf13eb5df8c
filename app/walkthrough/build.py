"""Rendering a walkthrough's steps headless: ``pbs walkthrough`` (docs/walkthrough.md).

Every image uses projector-ready framing (``app.frame.camera.fit_scene``): at any
``size`` the scene's whole framing stays in view. Per step:

- a view: the scene rendered, each object labelled (its ``name``, or the step's labels);
- a comparison: side A and side B (``app.render.compare.Comparison``, one shader cache)
  side by side, each with its label, and the magnified difference |A - B| x ``GAIN``;
- a sweep: a strip of frames, the value under each;
- a plot: ``pbs brdf``'s figure (``app.brdf.plot``) of the step's materials.

``app.walkthrough.handout.write_handout`` turns the result into the offline HTML handout
and its Markdown version.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from app.frame.camera import fit_scene
from app.gl.context import GLContext
from app.output import write_png
from app.progress import Progress
from app.render.compare import CompareSpec, Comparison
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene
from app.walkthrough.labels import (
    HANGUL_FAMILY,
    PlacedLabel,
    band_layout,
    caption_band,
    find_font,
    font_size,
    label_objects,
)
from app.walkthrough.model import Comparison as ComparisonItem
from app.walkthrough.model import Lang, LoadedStep, Plot, Sweep, View, with_values

if TYPE_CHECKING:
    from app.brdf.plot import FigureWords

GAIN = 8.0  # the difference image's magnification, as pbs render --compare-mode difference
SEPARATOR = 4  # pixels of dark grey between the panels of a comparison or a sweep
SEPARATOR_RGB = (40, 40, 40)

WORDS: dict[str, dict[Lang, str]] = {
    "difference": {"en": f"difference |A − B| × {GAIN:g}", "ko": f"차이 |A − B| × {GAIN:g}"},
}


def image_size(loaded: LoadedScene, size: tuple[int, int] | None) -> tuple[int, int]:
    """The size a scene renders at: ``size``, or the scene's own."""
    if size is not None:
        return size
    return loaded.scene.render.width, loaded.scene.render.height


def _hstack(images: list[np.ndarray]) -> np.ndarray:
    """Images side by side on a dark separator, tops aligned, padded to one height."""
    h = max(im.shape[0] for im in images)
    parts: list[np.ndarray] = []
    for k, im in enumerate(images):
        if k:
            parts.append(np.full((h, SEPARATOR, 3), SEPARATOR_RGB, np.uint8))
        pad = h - im.shape[0]
        parts.append(np.pad(im, ((0, pad), (0, 0), (0, 0))) if pad else im)
    return np.concatenate(parts, axis=1)


@dataclass
class ViewImages:
    """A view: the plain render, the labelled image, the labels (each with its box: left,
    top, right, bottom, right and bottom exclusive, and its leader line if it has one),
    the objects whose label found no free place, and the linear HDR radiance."""

    plain: np.ndarray
    labelled: np.ndarray
    labels: list[PlacedLabel]
    left_out: list[int]
    hdr: np.ndarray

    @property
    def boxes(self) -> list[tuple[int, int, int, int]]:
        return [label.box for label in self.labels]


def label_texts(view: View, loaded: LoadedScene, lang: Lang) -> dict[int, str]:
    """Object index -> label text: the objects' names, the step's labels, or none."""
    objects = loaded.scene.objects
    if view.labels == "none":
        return {}
    if view.labels == "names":
        return {i: obj.name for i, obj in enumerate(objects) if obj.name}
    names = [obj.name for obj in objects]
    out = {}
    for label in view.labels:
        index = label.object if isinstance(label.object, int) else names.index(label.object)
        out[index] = label.text.get(lang)
    return out


def render_view(
    gl: GLContext, view: View, loaded: LoadedScene, size: tuple[int, int] | None, lang: Lang
) -> ViewImages:
    """The view's scene rendered at ``size`` (fitted) and labelled."""
    size = image_size(loaded, size)
    renderer = Renderer(gl, fit_scene(loaded, size), size)
    renderer.want_hdr()  # both images: one lighting pass
    try:
        renderer.render()
        plain = renderer.read_ldr()
        hdr = renderer.read_hdr()
        labelled, placed, left_out = label_objects(
            plain, renderer, label_texts(view, loaded, lang), find_font(lang)
        )
    finally:
        renderer.release()
    return ViewImages(plain, labelled, placed, left_out, hdr)


@dataclass
class ComparisonImages:
    """A comparison: both sides' display images, the magnified difference, the panel
    (A | B | difference, labelled) and both sides' linear HDR radiance."""

    a: np.ndarray
    b: np.ndarray
    difference: np.ndarray
    panel: np.ndarray
    hdr: tuple[np.ndarray, np.ndarray]


def render_comparison(
    gl: GLContext,
    item: ComparisonItem,
    loaded: LoadedScene,
    size: tuple[int, int] | None,
    lang: Lang,
) -> ComparisonImages:
    """Both sides of the comparison and their difference |A - B| x ``GAIN``."""
    size = image_size(loaded, size)
    spec = CompareSpec(item.key, item.a, item.b, origin=f"{loaded.path.stem} comparison")
    comparison = Comparison(gl, fit_scene(loaded, size), spec, size)
    try:
        comparison.render()
        a, b = (renderer.read_ldr() for renderer in comparison.renderers)
        hdr = comparison.read_sides()
        comparison.composite("difference", gain=GAIN)
        difference = comparison.read_ldr()
    finally:
        comparison.release()
    face = find_font(lang)
    text = font_size(size[1], 3 * size[0])
    panel = _hstack(
        [
            caption_band(a, item.label_a.get(lang), face, text),
            caption_band(b, item.label_b.get(lang), face, text),
            caption_band(difference, WORDS["difference"][lang], face, text),
        ]
    )
    return ComparisonImages(a, b, difference, panel, hdr)


@dataclass
class SweepImages:
    """A sweep: its values, each frame's display image and HDR radiance, and the strip
    with the values."""

    values: list[float]
    frames: list[np.ndarray]
    strip: np.ndarray
    hdrs: list[np.ndarray]


def sweep_frame_size(size: tuple[int, int], steps: int) -> tuple[int, int]:
    """One frame of a sweep: the strip is about 2.5 images wide whatever the steps."""
    w, h = size
    frame_w = max(64, round(w * min(1.0, 2.5 / steps)))
    return frame_w, max(16, round(frame_w * h / w))


def sweep_label(sweep: Sweep, value: float, lang: Lang) -> str:
    """The text under a sweep's frame (``Sweep.value_text``)."""
    return sweep.value_text(value, lang)


def render_sweep(
    gl: GLContext,
    sweep: Sweep,
    step: LoadedStep,
    where: str,
    size: tuple[int, int] | None,
    lang: Lang,
) -> SweepImages:
    """One frame per value of the sweep, and the strip. One renderer shows every value:
    ``Renderer.update`` rebuilds only what the swept keys change (a material value keeps
    the meshes and the programs)."""
    loaded = step.scene(sweep.scene)
    frame = sweep_frame_size(image_size(loaded, size), sweep.steps)
    frames, hdrs = [], []
    renderer = None
    try:
        for value in sweep.values():
            scene = fit_scene(with_values(loaded, sweep.keys, value, step.path, where, where),
                              frame)  # fmt: skip
            if renderer is None:
                renderer = Renderer(gl, scene, frame)
                renderer.want_hdr()  # both images of every frame: one lighting pass each
            else:
                renderer.update(scene.scene)
            renderer.render()
            frames.append(renderer.read_ldr())
            hdrs.append(renderer.read_hdr())
    finally:
        if renderer is not None:
            renderer.release()
    face = find_font(lang)
    texts = [sweep_label(sweep, v, lang) for v in sweep.values()]
    size, rows = band_layout(texts, face, font_size(frame[1], sweep.steps * frame[0]), frame[0])
    strip = _hstack(
        [
            caption_band(im, text, face, size, where="below", rows=rows)
            for im, text in zip(frames, texts, strict=True)
        ]
    )
    return SweepImages(sweep.values(), frames, strip, hdrs)


def plot_dpi(size: tuple[int, int] | None) -> int:
    """The plot's resolution: ``pbs brdf``'s 100 dpi, less for a small ``--size``."""
    if size is None:
        return 100
    return max(40, min(100, round(100 * size[1] / 540)))


def figure_font(lang: Lang) -> tuple[tuple[str, ...] | None, tuple[str, ...]]:
    """The font families and files every figure of ``lang`` draws its words in
    (app/brdf/plot.py ``figure_font``): matplotlib's default for English, the labels'
    Hangul font (its Latin and Greek too) for Korean."""
    if lang == "en":
        return None, ()
    return (HANGUL_FAMILY, "DejaVu Sans"), (str(find_font(lang).path),)


def figure_words(lang: Lang) -> FigureWords:
    """The words of ``pbs brdf``'s figure in ``lang``: English as ``pbs brdf`` writes
    them, or Korean in the labels' Hangul font (its Latin and Greek too)."""
    from app.brdf.plot import FigureWords

    if lang == "en":
        return FigureWords()
    font, font_files = figure_font(lang)
    return FigureWords(
        evaluated_by="{where}로 계산한 f(l, v) (app.brdf.evaluate)",
        glsl="렌더러의 GLSL",
        reference="float64 기준 구현",
        subtitle="{model}, 거칠기 {roughness:g}, 금속성 {metallic:g}",
        angle="각도: θv (+ = 정반사 쪽, 점선: −θi 방향의 빛)",
        radius="반지름: {what} [1/sr], {how}{scale}",
        luminance="휘도",
        log_radius=", 로그 반지름",
        light_theta="빛의 입사각 θ (도)",
        albedo="방향 알베도 R(θ) = ∫ f (n·v) dv",
        quadrature="수치 적분 오차 ~ {error:.0e} (|R_8192 − R_2048|)",
        font=font,
        font_files=font_files,
    )


def render_plot(
    gl: GLContext, plot: Plot, size: tuple[int, int] | None, path: Path, lang: Lang = "en"
) -> None:
    """``pbs brdf``'s figure of the plot's materials, its words in ``lang``, written as
    PNG to ``path``."""
    from app.brdf import plot as brdf_plot

    materials = brdf_plot.parse_material_args(plot.materials)
    thetas = tuple(plot.theta) if plot.theta else brdf_plot.DEFAULT_THETAS
    if plot.kind != "lobes":  # app/brdf/figures.py, from the float64 twins
        from app.brdf import figures

        dpi, font = plot_dpi(size), figure_font(lang)  # words: figures.WORDS[lang]
        rough = sorted({m.params.roughness for m in materials})
        if plot.kind == "vndf":
            figure = figures.vndf_figure(rough, thetas, dpi, lang, *font)
        elif plot.kind == "prefilter":
            figure = figures.prefilter_figure(figures.prefilter_strip(gl, rough), dpi, lang, *font)
        else:
            params = [m.params for m in materials]
            figure = figures.layered_furnace_figure(params, dpi, lang, *font)
        brdf_plot.save_png(figure, path)
        return
    columns = brdf_plot.compute_columns(materials, thetas, "fcos", "glsl", gl=gl)
    figure = brdf_plot.render_figure(
        columns, "fcos", dpi=plot_dpi(size), backend="glsl", words=figure_words(lang)
    )
    brdf_plot.save_png(figure, path)


@dataclass
class Figure:
    """One image of a step in the handout: its file (relative to the output folder),
    its kind, its caption (None: none) and its alternative text; with ``build(...,
    keep=True)`` also the rendered images (None for a plot)."""

    kind: str
    image: str
    caption: str | None
    alt: str
    result: ViewImages | ComparisonImages | SweepImages | None = None


@dataclass
class RenderedStep:
    """A step and its images, in the order the handout shows them."""

    loaded: LoadedStep
    figures: list[Figure] = field(default_factory=list)


def count_items(steps: list[LoadedStep]) -> int:
    """How many images ``build`` renders: the progress bar's plan."""
    return sum(
        len(s.step.views) + len(s.step.comparisons) + len(s.step.sweeps) + len(s.step.plots)
        for s in steps
    )


def build(
    gl: GLContext,
    steps: list[LoadedStep],
    out: Path,
    lang: Lang,
    size: tuple[int, int] | None = None,
    progress: Progress | None = None,
    keep: bool = False,
) -> list[RenderedStep]:
    """Render every step's images into ``out/images/`` and return what the handout shows
    (``keep``: with each figure's images and HDR radiance, for checks; memory grows with
    the number of images)."""
    images = out / "images"
    rendered = []
    find_font(lang)  # a missing Hangul font is reported before any rendering
    for loaded in steps:
        step = loaded.step
        done = RenderedStep(loaded)
        tasks: list[tuple[str, str, object]] = [
            *(("view", f"views[{i}]", v) for i, v in enumerate(step.views)),
            *(("comparison", f"comparisons[{i}]", c) for i, c in enumerate(step.comparisons)),
            *(("sweep", f"sweeps[{i}]", s) for i, s in enumerate(step.sweeps)),
            *(("plot", f"plots[{i}]", p) for i, p in enumerate(step.plots)),
        ]
        for kind, where, item in tasks:
            if progress is not None:
                progress.start(f"{loaded.slug} {where}")
            name = f"{loaded.slug}-{kind}-{where.split('[')[1].rstrip(']')}.png"
            path = images / name
            result: ViewImages | ComparisonImages | SweepImages | None
            if isinstance(item, View):
                result = render_view(gl, item, loaded.scene(item.scene), size, lang)
                write_png(path, result.labelled)
                alt = item.scene
            elif isinstance(item, ComparisonItem):
                result = render_comparison(gl, item, loaded.scene(item.scene), size, lang)
                write_png(path, result.panel)
                alt = f"{item.scene}: {item.key} = {item.a!r} | {item.b!r}"
            elif isinstance(item, Sweep):
                result = render_sweep(gl, item, loaded, where, size, lang)
                write_png(path, result.strip)
                alt = f"{item.scene}: {', '.join(item.keys)} {item.start:g} .. {item.to:g}"
            else:
                assert isinstance(item, Plot)
                path.parent.mkdir(parents=True, exist_ok=True)
                render_plot(gl, item, size, path, lang)
                result = None
                alt = "BRDF: " + "; ".join(item.materials)
            caption = item.caption.get(lang) if item.caption is not None else None
            kept = result if keep else None
            done.figures.append(Figure(kind, f"images/{name}", caption, alt, kept))
            if progress is not None:
                progress.tick()
                progress.done()
        rendered.append(done)
    return rendered
