"""Shared fixtures: real headless GL contexts on Mesa (EGL and OSMesa), no mocks."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.gl.context import GLContext, create_context

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module", params=["egl", "osmesa"])
def gl(request: pytest.FixtureRequest) -> GLContext:
    """A headless OpenGL 3.3 context from each backend in turn."""
    context = create_context(request.param)
    yield context
    context.release()


@pytest.fixture(scope="module")
def gl_egl() -> GLContext:
    """The EGL context alone, for tests where the backend does not matter."""
    context = create_context("egl")
    yield context
    context.release()


@pytest.fixture(scope="session")
def xdisplay() -> str:
    """A private X server (Xvfb, installed by scripts/dev.sh) for tests that open real
    windows; DISPLAY points at it for the rest of the session."""
    from app.viewer.xvfb import xvfb

    try:
        with xvfb() as display:
            yield display
    except RuntimeError as exc:
        pytest.fail(str(exc))


# Markers (registered in pyproject.toml; README.md, "Tests"). A test that takes a fixture
# below, directly or through another fixture, gets the marker by that alone; a test that
# makes its GL context another way (a renderer built in the test, a `pbs` child process
# that renders) carries `gl` itself, as a module's `pytestmark` or on the test.
FIXTURE_MARKERS = {"gl": "gl", "gl_egl": "gl", "xdisplay": "viewer"}


def _mark_by_fixtures(item: pytest.Item) -> None:
    """``gl`` for the GL context fixtures, ``viewer`` (and so ``gl``) for the X server."""
    used = set(getattr(item, "fixturenames", ()))
    for marker in sorted({FIXTURE_MARKERS[f] for f in used & FIXTURE_MARKERS.keys()}):
        item.add_marker(marker)
    if "viewer" in item.keywords or "browser" in item.keywords:
        item.add_marker("gl")  # a window draws with GL; the handout's images are rendered


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Markers from fixtures (above); and tests marked ``whole`` (an attack suite at full
    size, docs/stability.md) run only when ``-m`` names the marker; every run has their
    sampled versions."""
    for item in items:
        _mark_by_fixtures(item)
    if "whole" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="the whole attack suite: run with -m whole")
    for item in items:
        if "whole" in item.keywords:
            item.add_marker(skip)
