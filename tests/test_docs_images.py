"""The figures under docs/images: each one shown by a page, each image a page shows
present, and the figures the scripts write (scripts/antialiasing_figures.py,
scripts/nan_debug_figure.py) the ones their pages show. Pure Python: no GL context,
nothing rendered."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
IMAGES = REPO / "docs" / "images"
# a Markdown image or link into docs/images, from docs/ ("images/x.png") or the root
_SHOWN = re.compile(r"\]\((?:docs/)?(images/[^)\s]+)\)")


def _pages() -> dict[Path, str]:
    pages = [*sorted((REPO / "docs").glob("*.md")), REPO / "README.md"]
    return {p: p.read_text(encoding="utf-8") for p in pages}


def _shown() -> dict[str, list[str]]:
    """Each image path a page shows (relative to docs/) -> the pages that show it."""
    shown: dict[str, list[str]] = {}
    for page, text in _pages().items():
        for target in _SHOWN.findall(text):
            shown.setdefault(target, []).append(page.name)
    return shown


def test_every_docs_image_is_shown_by_a_page() -> None:
    shown = _shown()
    unshown = [p.name for p in sorted(IMAGES.iterdir()) if f"images/{p.name}" not in shown]
    assert not unshown, f"docs/images files no page shows: {unshown}"


def test_every_image_a_page_shows_exists() -> None:
    missing = {t: pages for t, pages in _shown().items() if not (REPO / "docs" / t).is_file()}
    assert not missing, f"images shown but absent from docs/images: {missing}"


def _script(name: str):
    """scripts/NAME.py imported as a module (its figures' names are constants of it)."""
    spec = importlib.util.spec_from_file_location(name, REPO / "scripts" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    return script


def test_the_antialiasing_figures_are_their_generators() -> None:
    """docs/antialiasing.md shows exactly the antialiasing figures the script writes,
    and they are in docs/images (a figure renamed on one side alone fails here)."""
    script = _script("antialiasing_figures")
    written = {script.MODES_FIGURE, script.GBAA_FIGURE}
    page = (REPO / "docs" / "antialiasing.md").read_text(encoding="utf-8")
    shown = {Path(t).name for t in _SHOWN.findall(page)}
    assert shown == written
    on_disk = {p.name for p in IMAGES.glob("antialiasing-*")}
    assert on_disk == written


def test_the_nan_debug_figure_is_its_generators() -> None:
    """The NaN debug view's figure docs/stability.md shows is the one
    scripts/nan_debug_figure.py writes, and it is in docs/images."""
    figure = _script("nan_debug_figure").FIGURE
    page = (REPO / "docs" / "stability.md").read_text(encoding="utf-8")
    shown = {Path(t).name for t in _SHOWN.findall(page)}
    assert figure in shown
    assert (IMAGES / figure).is_file()
