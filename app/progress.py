"""A progress bar on stderr: tasks done of the plan, frames of the current task, time.

Two uses: the bench's tasks (``start``/``tick``/``done``: frames timed inside one task)
and ``pbs batch``'s jobs (``job``: one call per finished job, with its own seconds, the
rate of rendered jobs and an estimate of the time left).
"""

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
        self.timed = 0  # jobs that did work (not skipped): the ones a rate may count

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

    def job(self, label: str, seconds: float, timed: bool = True) -> None:
        """One job of a batch ended after ``seconds`` of its own work.

        ``timed`` is false for a job that did no work (skipped on resume): it counts as
        done but not in the rate, so the estimate of the time left stays that of the jobs
        still to render. On a terminal the line is redrawn in place, a newline after the
        last job; otherwise a line per job.
        """
        self.finished += 1
        self.timed += timed
        if not self.enabled:
            return
        filled = round(self.WIDTH * min(self.finished, self.total) / self.total)
        bar = "#" * filled + "-" * (self.WIDTH - filled)
        elapsed = time.perf_counter() - self.started
        left = max(self.total - self.finished, 0)
        pace = f"total {self._elapsed(self.started)}"
        if self.timed and elapsed > 0:
            rate = self.timed / elapsed
            pace += f", {rate:.2f} jobs/s"
            if left:
                s = int(left / rate)
                pace += f", ETA {s // 60}m{s % 60:02d}s"
        own = f"{seconds * 1000:.0f} ms" if seconds < 1 else f"{seconds:.2f} s"
        took = f"{own}; " if timed else ""
        line = f"[{bar}] {self.finished}/{self.total} {label} ({took}{pace})"
        final = left == 0
        if self.interactive:
            self.stream.write("\r\x1b[2K" + line + ("\n" if final else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def add(self, tasks: int) -> None:
        """The plan grew (e.g. an optional comparison turned out to be available)."""
        self.total += tasks
