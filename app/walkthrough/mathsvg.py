"""LaTeX (matplotlib's mathtext subset) to inline SVG, with no network and no TeX install.

matplotlib's mathtext lays out the formula with its bundled Computer Modern fonts, and
its SVG backend writes every glyph as a path (``svg.fonttype = "path"``), so the handout
needs no font and no script to show an equation. ``check_latex`` parses a formula
without drawing it: a step's bad LaTeX is refused when the step is loaded.
``latex_to_rgba`` rasterises the same formula for the desktop viewer's panel.
"""

from __future__ import annotations

import io
import itertools
import re
from dataclasses import dataclass

import numpy as np

_RC = {"mathtext.fontset": "cm", "svg.fonttype": "path", "svg.hashsalt": "pbs-walkthrough"}

# Matplotlib's SVG preamble and metadata name URLs (the DTD, Dublin Core, its home page);
# none is fetched by a browser, but the handout must name no network address at all.
_PREAMBLE = re.compile(r"\A.*?(?=<svg\b)", re.S)
_METADATA = re.compile(r"<metadata>.*?</metadata>\s*", re.S)
_XMLNS = re.compile(r'\s+xmlns(?::\w+)?="[^"]*"')
_COMMENT = re.compile(r"<!--.*?-->\s*", re.S)  # the LaTeX source, as a comment
_BACKGROUND = re.compile(r'<g id="patch_1">.*?</g>\s*', re.S)  # the white figure patch
_IDS = itertools.count()


@dataclass(frozen=True)
class MathSVG:
    """One formula as inline SVG markup, and its depth below the text baseline (pt)."""

    svg: str
    width_pt: float
    height_pt: float
    depth_pt: float


def _wrap(latex: str) -> str:
    return f"${latex}$"


def check_latex(latex: str) -> str | None:
    """None if mathtext can lay out ``latex`` (without the ``$``), else the parser's
    complaint on one line."""
    from matplotlib.mathtext import MathTextParser

    if not latex.strip():
        return "empty formula"
    try:
        MathTextParser("path").parse(_wrap(latex))
    except ValueError as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        return lines[-1] if lines else "mathtext cannot parse it"
    return None


def latex_to_svg(latex: str, size_pt: float = 15.0) -> MathSVG:
    """``latex`` drawn at ``size_pt`` as ``<svg>`` markup for an HTML page: no XML
    preamble, no namespaces or metadata URLs, no background, ids made unique to this
    formula (many formulas share one page), and the source kept as ``aria-label``."""
    import matplotlib
    from matplotlib import mathtext
    from matplotlib.font_manager import FontProperties

    prop = FontProperties(size=size_pt)
    buffer = io.StringIO()
    with matplotlib.rc_context(_RC):
        width, height, depth, *_ = mathtext.MathTextParser("path").parse(
            _wrap(latex), dpi=72, prop=prop
        )
        mathtext.math_to_image(_wrap(latex), buffer, prop=prop, format="svg")
    svg = buffer.getvalue()
    for pattern in (_PREAMBLE, _METADATA, _XMLNS, _COMMENT, _BACKGROUND):
        svg = pattern.sub("", svg)
    prefix = f"m{next(_IDS)}-"
    svg = svg.replace('id="', f'id="{prefix}').replace('href="#', f'href="#{prefix}')
    label = latex.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace("$", "")
    svg = svg.replace("<svg ", f'<svg role="img" aria-label="{label}" ', 1)
    return MathSVG(svg.strip(), float(width), float(height), float(depth))


def latex_to_rgba(latex: str, size_px: float) -> tuple[np.ndarray, float]:
    """``latex`` rasterised by mathtext's Agg backend at a font size of ``size_px``
    pixels: an (H, W, 4) uint8 image, white text on transparent (the alpha is the
    glyphs' coverage), rows top to bottom, and the depth below the baseline in pixels.
    The viewer uploads it as a texture and draws it in its panels."""
    import matplotlib
    from matplotlib import mathtext
    from matplotlib.font_manager import FontProperties

    with matplotlib.rc_context(_RC):
        parsed = mathtext.MathTextParser("agg").parse(
            _wrap(latex), dpi=72, prop=FontProperties(size=size_px)
        )
    alpha = np.asarray(parsed.image, np.uint8)
    rgba = np.empty((*alpha.shape, 4), np.uint8)
    rgba[..., :3] = 255
    rgba[..., 3] = alpha
    return rgba, float(parsed.depth)
