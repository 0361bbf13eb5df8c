"""A pytest plugin for tests/test_drivers.py's child runs (``-p tests.gl_renderer_header``):
the report header names the GL_RENDERER of an EGL context made in the run's own process,
so the parent can tell which Mesa driver ran the tests. Mesa picks the driver once per
process from its environment, so every context the tests make is that driver's."""

from __future__ import annotations

import pytest

HEADER = "GL_RENDERER: "


def pytest_report_header(config: pytest.Config) -> str:
    from app.gl.context import create_context

    gl = create_context("egl")
    try:
        return HEADER + gl.renderer
    finally:
        gl.release()
