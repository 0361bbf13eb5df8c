"""A private X server (Xvfb) for windows on machines without a display: the viewer's tests
and the bench's latency rows open real glfw windows on it."""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def xvfb(screen: str = "1600x1000x24") -> Iterator[str]:
    """Start Xvfb on a free display, point DISPLAY at it, yield the display name, and stop
    it afterwards (DISPLAY restored). RuntimeError where Xvfb is missing or will not
    start (scripts/dev.sh installs it)."""
    if shutil.which("Xvfb") is None:
        raise RuntimeError("Xvfb is missing: run `bash scripts/dev.sh setup` (it installs it)")
    read, write = os.pipe()
    server = subprocess.Popen(
        # -displayfd: Xvfb picks a free display and writes its number to the pipe;
        # -noreset: keep serving when the last window closes (no gap while it resets).
        ["Xvfb", "-displayfd", str(write), "-screen", "0", screen, "-nolisten", "tcp",
         "-noreset"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()
    if not number:
        server.kill()
        raise RuntimeError("Xvfb did not start")
    previous = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = f":{number}"
    try:
        yield os.environ["DISPLAY"]
    finally:
        server.terminate()
        server.wait(timeout=10)
        if previous is None:
            os.environ.pop("DISPLAY", None)
        else:
            os.environ["DISPLAY"] = previous
