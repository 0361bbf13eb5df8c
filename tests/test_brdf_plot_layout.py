"""The BRDF figure's words stay readable (app/brdf/plot.py, as ``pbs brdf`` and the
walkthrough's handout draw it, in English and Korean): every title inside the figure,
the albedo plot's quadrature note crossed by no curve. Step 5's plot, glass seen from air
and from inside, is the case that showed both: a name of every inline key ran past the
right edge, and the external albedo's 0.04 ran through the note at the bottom left."""

from __future__ import annotations

import numpy as np
import pytest

from app.brdf import plot as brdf_plot
from app.walkthrough.build import figure_words, plot_dpi

MATERIALS = [
    '{ ior = 1.5, fresnel = "dielectric", diffuse = "none", roughness = 0.1 }',
    '{ ior = 1.0, medium_ior = 1.5, fresnel = "dielectric", diffuse = "none", roughness = 0.1 }',
]


@pytest.fixture(scope="module")
def columns() -> list:
    materials = brdf_plot.parse_material_args(MATERIALS)
    return brdf_plot.compute_columns(materials, (0.0, 30.0, 60.0), "fcos", "reference")


@pytest.mark.parametrize("lang", ["en", "ko"])
def test_step_5_figure_keeps_its_words_clear(columns: list, lang: str) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    words = figure_words(lang)
    figure = brdf_plot.render_figure(
        columns, "fcos", dpi=plot_dpi((640, 360)), backend="reference", words=words
    )
    with brdf_plot.figure_font(words.font, words.font_files):
        canvas = FigureCanvasAgg(figure)
        canvas.draw()
        renderer = canvas.get_renderer()
        width = figure.bbox.width
        texts = [t for t in figure.findobj(Text) if t.get_visible() and t.get_text()]
        for text in texts:
            box = text.get_window_extent(renderer)
            assert box.x0 >= 0.0 and box.x1 <= width, f"{text.get_text()!r}: {box}"
        notes = [t for t in texts if "R_8192" in t.get_text()]
        assert len(notes) == 2
        for note in notes:
            box = note.get_window_extent(renderer).padded(2.0)
            ax = note.axes  # the albedo plot it belongs to
            for line in ax.get_lines():
                x, y = line.get_data()
                if not isinstance(line, Line2D) or len(x) < 2:
                    continue
                dense = np.linspace(0.0, len(x) - 1.0, 20 * len(x))
                points = np.c_[
                    np.interp(dense, np.arange(len(x)), np.asarray(x, float)),
                    np.interp(dense, np.arange(len(y)), np.asarray(y, float)),
                ]
                shown = ax.transData.transform(points)
                inside = (
                    (shown[:, 0] >= box.x0)
                    & (shown[:, 0] <= box.x1)
                    & (shown[:, 1] >= box.y0)
                    & (shown[:, 1] <= box.y1)
                )
                assert not inside.any(), f"{line.get_label()!r} crosses {note.get_text()!r}"
