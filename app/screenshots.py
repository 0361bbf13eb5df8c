"""Regenerate ``screenshots/NAME.png`` for every scene ``scenes/NAME.toml``.

``python -m app.screenshots [--backend egl|osmesa]``; the regression test renders each
scene again and compares with these images perceptually (FLIP).
``python -m app.screenshots --handout`` instead writes ``screenshots/walkthrough-handout.png``:
the first page of the walkthrough's Korean handout as headless Chromium shows it.
``python -m app.screenshots --viewer-walkthrough`` writes ``screenshots/viewer-walkthrough.png``:
the desktop viewer's window (a real glfw window on a private Xvfb) on the Korean
walkthrough's step 1 with its first comparison in the split screen.
``python -m app.screenshots --viewer`` writes ``screenshots/viewer.png``: the viewer on the
showcase with its gold sphere selected (README, docs/viewer.md).
``--handout-questions`` and ``--viewer-questions`` write ``screenshots/walkthrough-questions.png``
and ``screenshots/viewer-questions.png``: step 3's predict-then-reveal question in the Korean
handout and in the viewer, its answer revealed (docs/walkthrough.md, "Questions").
``--handout-prefilter`` writes ``screenshots/walkthrough-prefilter.png``: step 4's figure of
the environment prefilter's Monte Carlo against its exact integral in the Korean handout
(docs/ibl.md).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.gl.context import GLContext, create_context
from app.output import write_png
from app.render.renderer import Renderer
from app.resources import scenes_dir
from app.scene.loader import load_scene

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"
SHOTS = REPO / "screenshots"


def scene_files() -> list[Path]:
    """Every scene of the repository, sorted by name."""
    return sorted(SCENES.glob("*.toml"))


def render_scene(gl: GLContext, path: Path) -> np.ndarray:
    """The display image of one scene at its own size, (H, W, 3) uint8."""
    renderer = Renderer(gl, load_scene(path))
    try:
        renderer.render()
        return renderer.read_ldr()
    finally:
        renderer.release()


HANDOUT_PAGE = (1000, 1400)  # CSS pixels: about an A4 page's proportions


def handout_screenshot(gl: GLContext, out: Path, lang: str = "ko") -> None:
    """The walkthrough's handout (every bundled step, images 640x360) as Chromium shows
    its first ``HANDOUT_PAGE``, written as PNG to ``out``."""
    import tempfile

    from app.output import atomic_write
    from app.resources import walkthrough_dir
    from app.walkthrough.browser import Browser
    from app.walkthrough.build import build
    from app.walkthrough.handout import write_handout
    from app.walkthrough.model import load_walkthrough

    with tempfile.TemporaryDirectory(prefix="pbs-handout-") as tmp:
        folder = Path(tmp)
        rendered = build(gl, load_walkthrough(walkthrough_dir()), folder, lang, (640, 360))
        page, _ = write_handout(folder, rendered, lang)
        with Browser(*HANDOUT_PAGE) as browser:
            browser.open(page)
            png = browser.screenshot()
    atomic_write(out, lambda tmp_file: tmp_file.write_bytes(png))


def _handout_element_screenshot(
    gl: GLContext, out: Path, section: int, lang: str, element_js: str, before_js: str = ""
) -> None:
    """The handout's step of RTR4 §9.``section`` in ``lang`` (images 640x360) as Chromium
    shows it after running ``before_js``, cropped to the element ``element_js`` (a JS
    expression) with an 8-pixel margin, written as PNG to ``out``."""
    import tempfile

    from app.output import atomic_write
    from app.resources import walkthrough_dir
    from app.walkthrough.browser import Browser
    from app.walkthrough.build import build
    from app.walkthrough.handout import write_handout
    from app.walkthrough.model import load_walkthrough

    with tempfile.TemporaryDirectory(prefix="pbs-handout-") as tmp:
        folder = Path(tmp)
        steps = load_walkthrough(walkthrough_dir(), {section})
        rendered = build(gl, steps, folder, lang, (640, 360))
        page, _ = write_handout(folder, rendered, lang)
        with Browser(900, 1400) as browser:
            browser.open(page)
            if before_js:
                browser.evaluate(before_js)
            box = browser.evaluate(
                f"(() => {{ const e = {element_js}; e.scrollIntoView();"
                " const r = e.getBoundingClientRect();"
                " return {x: r.x - 8, y: r.y + window.scrollY - 8,"
                " width: r.width + 16, height: r.height + 16}; })()"
            )
            png = browser.screenshot(clip=box, full_page=True)
    atomic_write(out, lambda tmp_file: tmp_file.write_bytes(png))


def handout_questions_screenshot(
    gl: GLContext, out: Path, section: int = 3, lang: str = "ko"
) -> None:
    """The questions of the handout's step of RTR4 §9.``section`` in ``lang`` as Chromium
    shows them with the first answer revealed (its Reveal label clicked), cropped to the
    questions' box, written as PNG to ``out``."""
    _handout_element_screenshot(
        gl, out, section, lang, "document.querySelector('.questions')",
        "document.querySelector('label.reveal').click()",
    )  # fmt: skip


def handout_plot_screenshot(
    gl: GLContext, out: Path, section: int = 4, plot: int = 0, lang: str = "ko"
) -> None:
    """Plot ``plot`` of the handout's step of RTR4 §9.``section`` in ``lang`` as Chromium
    shows it with its caption, cropped to its figure, written as PNG to ``out`` (step 4's:
    the environment prefilter's Monte Carlo against its exact integral)."""
    _handout_element_screenshot(
        gl, out, section, lang,
        f"document.querySelector('img[src$=\"-plot-{plot}.png\"]').closest('figure')",
    )  # fmt: skip


VIEWER_WINDOW = (1280, 720)


def viewer_questions_screenshot(out: Path, section: int = 3, lang: str = "ko") -> None:
    """The viewer on the walkthrough's step of RTR4 §9.``section`` in ``lang`` with its
    first question revealed (the question's view opened, the panel scrolled to it),
    written as PNG to ``out``."""
    from app.viewer.window import Viewer
    from app.viewer.xvfb import xvfb

    with xvfb():
        viewer = Viewer(None, VIEWER_WINDOW, vsync=False, hangul=lang == "ko")
        try:
            if not viewer.open_walkthrough(lang=lang, section=section):
                raise RuntimeError(viewer.state.error)
            if not viewer.lesson.reveal(0):
                raise RuntimeError(viewer.state.error)
            viewer.lesson.focus = 0
            viewer.settle()
            viewer.step(4)  # laid out, scrolled to the question, every formula uploaded
            write_png(out, viewer.read_window())
        finally:
            viewer.close()


def viewer_walkthrough_screenshot(out: Path, section: int = 1, lang: str = "ko") -> None:
    """The viewer's window, panels included, on the walkthrough's step of RTR4
    §9.``section`` in ``lang`` with the step's first comparison started (as its button
    does), written as PNG to ``out``."""
    from app.viewer.window import Viewer
    from app.viewer.xvfb import xvfb

    with xvfb():
        viewer = Viewer(None, VIEWER_WINDOW, vsync=False, hangul=lang == "ko")
        try:
            if not viewer.open_walkthrough(lang=lang, section=section):
                raise RuntimeError(viewer.state.error)
            if not viewer.lesson.compare(0):
                raise RuntimeError(viewer.state.error)
            viewer.settle()
            viewer.step(3)  # the panels laid out, every formula uploaded
            write_png(out, viewer.read_window())
        finally:
            viewer.close()


def viewer_screenshot(out: Path, material: str = "gold") -> None:
    """The viewer's window on scenes/showcase.toml with the first object of ``material``
    selected (its Material panel in front of the docked tabs), written as PNG to ``out``."""
    from app.viewer.window import Selection, Viewer
    from app.viewer.xvfb import xvfb

    with xvfb():
        viewer = Viewer(scenes_dir() / "showcase.toml", VIEWER_WINDOW, vsync=False)
        try:
            objects = viewer.scene.objects
            index = next(i for i, obj in enumerate(objects) if obj.material == material)
            viewer.selection = Selection(index, material)
            viewer.panels.expand("Material")
            viewer.settle()
            viewer.step(3)  # the panels laid out, the plots drawn
            write_png(out, viewer.read_window())
        finally:
            viewer.close()


# The screenshots that are not a scene's: flag -> (file, what it needs, how it is made;
# the handout's take the GL context, the viewer's open their own window).
SINGLE_SHOTS: dict[str, tuple[str, str, Callable[..., None]]] = {
    "handout": ("walkthrough-handout.png", "chromium", handout_screenshot),
    "handout-questions": ("walkthrough-questions.png", "chromium", handout_questions_screenshot),
    "handout-prefilter": ("walkthrough-prefilter.png", "chromium", handout_plot_screenshot),
    "viewer": ("viewer.png", "Xvfb", viewer_screenshot),
    "viewer-walkthrough": ("viewer-walkthrough.png", "Xvfb", viewer_walkthrough_screenshot),
    "viewer-questions": ("viewer-questions.png", "Xvfb", viewer_questions_screenshot),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    for flag, (name, needs, _) in SINGLE_SHOTS.items():
        parser.add_argument(
            f"--{flag}", action="store_true", help=f"write only screenshots/{name} (needs {needs})"
        )
    args = parser.parse_args(argv)
    for flag, (name, needs, make) in SINGLE_SHOTS.items():
        if not getattr(args, flag.replace("-", "_")):
            continue
        out = SHOTS / name
        if needs == "Xvfb":
            make(out)
        else:
            gl = create_context(args.backend)
            make(gl, out)
            gl.release()
        print(out.relative_to(REPO))
        return 0
    gl = create_context(args.backend)
    for path in scene_files():
        out = SHOTS / f"{path.stem}.png"
        write_png(out, render_scene(gl, path))
        print(out.relative_to(REPO))
    gl.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
