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
    import os
    import shutil
    import subprocess

    if shutil.which("Xvfb") is None:
        pytest.fail("Xvfb is missing: run `bash scripts/dev.sh setup` (it installs it)")
    read, write = os.pipe()
    server = subprocess.Popen(
        [
            "Xvfb",
            "-displayfd",
            str(write),
            "-screen",
            "0",
            "1600x1000x24",
            "-nolisten",
            "tcp",
            "-noreset",  # keep serving when the last window closes (no reset gap)
        ],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    if not number:
        server.kill()
        pytest.fail("Xvfb did not start")
    previous = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = f":{number}"
    yield os.environ["DISPLAY"]
    server.terminate()
    server.wait(timeout=10)
    if previous is None:
        os.environ.pop("DISPLAY", None)
    else:
        os.environ["DISPLAY"] = previous
