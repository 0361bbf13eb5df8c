"""A progress bar on stderr: tasks done of the plan, frames of the current task, time."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """``start(label)`` a task, ``tick()`` per frame, ``done()`` when it ends.

    On a terminal one line is redrawn in place; otherwise (a log file, pytest) a line is
    written per task, so the log shows what ran and for how long.
    """

    WIDTH = 24

    def __init__(self, total: int, stream: TextIO | None = None, enabled: bool = True) -> None:
        self.total = max(total, 1)
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.finished = 0
        self.frames = 0
        self.label = ""
        self.started = time.perf_counter()
        self.task_started = self.started
        self.interactive = bool(getattr(self.stream, "isatty", lambda: False)())

    def _elapsed(self, since: float) -> str:
        s = int(time.perf_counter() - since)
        return f"{s // 60}m{s % 60:02d}s"

    def _draw(self, final: bool = False) -> None:
        if not self.enabled:
            return
        filled = round(self.WIDTH * self.finished / self.total)
        bar = "#" * filled + "-" * (self.WIDTH - filled)
        line = (
            f"[{bar}] {self.finished}/{self.total} {self.label}"
            f" ({self.frames} frames, {self._elapsed(self.task_started)};"
            f" total {self._elapsed(self.started)})"
        )
        if self.interactive:
            self.stream.write("\r\x1b[2K" + line + ("\n" if final else ""))
            self.stream.flush()
        elif final:
            self.stream.write(line + "\n")
            self.stream.flush()

    def start(self, label: str) -> None:
        self.label = label
        self.frames = 0
        self.task_started = time.perf_counter()
        self._draw()

    def tick(self) -> None:
        self.frames += 1
        self._draw()

    def done(self) -> None:
        self.finished += 1
        self._draw(final=True)

    def add(self, tasks: int) -> None:
        """The plan grew (e.g. an optional comparison turned out to be available)."""
        self.total += tasks
