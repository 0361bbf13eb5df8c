"""The words of app/brdf/figures.py's figures (plot kinds ``vndf``, ``layered_furnace``,
``prefilter``) in the handout's language: on the Korean handout every title, axis name,
legend entry and table heading is Korean (figures.WORDS, docs/walkthrough.md's glossary)
and drawn in the Hangul font (app/walkthrough/build.py ``figure_font``); only symbols,
units, names and the materials' code names stay in Latin letters. The same check finds
the English words of the English figures, so it fails where the language is ignored."""

from __future__ import annotations

import re

import numpy as np

from app.brdf import figures
from app.brdf import plot as brdf_plot
from app.walkthrough.build import figure_font
from app.walkthrough.labels import HANGUL_FAMILY

# Latin words a figure's text may keep: symbols, units, names, the estimators' and
# materials' code names (the plot's input, as the scene file writes them)
KEPT = {
    "r", "l", "v", "n", "E", "F", "N", "R", "RGB", "VNDF", "GGX", "GLSL", "float64", "RMS",
    "L_pre", "Heitz", "weidlich_wilkie_series", "filament",
}  # fmt: skip
FURNACE = [
    "sec12_layered_furnace:white-weidlich-wilkie-series",
    "sec12_layered_furnace:white-filament",
]


def _texts(figure) -> list[tuple[str, list[str]]]:
    """(text, font families) of every non-empty text artist of ``figure``, the table's
    cells included (a table keeps its cells' texts outside ``findobj``)."""
    from matplotlib.table import Table
    from matplotlib.text import Text

    texts = list(figure.findobj(Text))
    for table in figure.findobj(Table):
        texts += [cell.get_text() for cell in table.get_celld().values()]
    return [(t.get_text(), t.get_fontfamily()) for t in texts if t.get_text().strip()]


def _foreign(text: str) -> list[str]:
    return [w for w in re.findall(r"[A-Za-z][A-Za-z0-9_]*", text) if w not in KEPT]


def _strip() -> figures.PrefilterStrip:
    """A made-up strip of two roughnesses (the figure's layout only reads its shapes)."""
    azimuth = np.linspace(-180.0, 180.0, 16)
    exact = np.stack([1.0 + 0.5 * np.cos(np.radians(azimuth))] * 2)
    counts = figures.PREFILTER_SAMPLE_COUNTS
    noise = np.array([[1.0 + 0.3 / np.sqrt(n) for n in counts]] * 2)[..., None]
    return figures.PrefilterStrip(
        (0.3, 0.7), counts, np.zeros((16, 3)), azimuth, exact, exact[:, None, :] * noise
    )


def _figures(lang: str, furnace: bool = True) -> dict[str, list[tuple[str, list[str]]]]:
    font = figure_font(lang)
    out = {
        "vndf": _texts(figures.vndf_figure([0.5], [45.0], 40, lang, *font)),
        "prefilter": _texts(figures.prefilter_figure(_strip(), 40, lang, *font)),
    }
    if furnace:  # the random walk takes seconds: built in Korean only
        params = [m.params for m in brdf_plot.parse_material_args(FURNACE)]
        out["layered_furnace"] = _texts(figures.layered_furnace_figure(params, 40, lang, *font))
    return out


def test_the_korean_figures_words_are_korean_in_the_hangul_font() -> None:
    for kind, texts in _figures("ko").items():
        foreign = [(t, _foreign(t)) for t, _ in texts if _foreign(t)]
        assert not foreign, (kind, foreign)
        hangul = [(t, family) for t, family in texts if re.search("[가-힣]", t)]
        assert len(hangul) >= 3, (kind, texts)
        assert all(family[0] == HANGUL_FAMILY for _, family in hangul), (kind, hangul)
    english = _figures("en", furnace=False)
    for kind, texts in english.items():
        assert sum(len(_foreign(t)) for t, _ in texts) >= 10, (kind, texts)
