"""Worker processes that survive each other: ``pbs batch --workers N``.

``concurrent.futures.ProcessPoolExecutor`` breaks as a whole when one worker dies (every
pending future fails with ``BrokenProcessPool``), and its workers and resource tracker
outlive a parent that is killed, holding the parent's stdout and stderr open. This pool is
smaller and keeps three promises (docs/batch.md, "Faults"):

- **A dead worker fails only the job it held.** Each worker runs one job at a time; when
  one dies (a driver crash, the OOM killer, ``kill -9``), its job gets a ``failed`` line
  saying how it died, a new worker takes its place and the run goes on.
- **The parent's death ends its workers.** Each worker asks the kernel for SIGKILL when
  its parent dies (``prctl(PR_SET_PDEATHSIG)``) and checks that the parent it was started
  by is still its parent, so none is left running, however the parent ended.
- **Workers hold nothing of the caller's.** They are started with ``subprocess`` (no fork
  of a process that has a GL context), stdin, stdout and stderr on /dev/null and only
  their two pipes passed, so a caller reading the parent's output sees it end when the
  parent does.

Jobs and results cross the pipes as length-prefixed pickles; the worker side is
``python -m app.batch.pool CHILD JOBS_FD RESULTS_FD PARENT_PID BACKEND DEVICE``. With
``devices`` (``pbs batch --devices 0,1``) worker k makes its context on
``devices[k % len(devices)]``, and a worker started in a dead one's place takes its device.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import selectors
import signal
import struct
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from app.batch.jobs import Job

_HEADER = struct.Struct("<Q")
PR_SET_PDEATHSIG = 1
# A worker that dies before finishing any job this many times in a row ends the run's
# remaining jobs as failed: the machine cannot run workers (no GL, say).
MAX_EARLY_DEATHS = 3


def _send(fd: int, obj: object) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view) :]


def _receive(fd: int) -> object | None:
    """The next object from ``fd``, or None at end of file."""
    head = _read_exactly(fd, _HEADER.size)
    if head is None:
        return None
    body = _read_exactly(fd, _HEADER.unpack(head)[0])
    return None if body is None else pickle.loads(body)


def _read_exactly(fd: int, n: int) -> bytes | None:
    chunks, left = [], n
    while left:
        chunk = os.read(fd, left)
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _die_with_parent(parent: int) -> None:
    """Ask for SIGKILL when the parent dies, and die now if it already has."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the pipe's end of file still ends us
        pass
    if os.getppid() != parent:
        os._exit(1)


def _child(jobs_fd: int, results_fd: int, parent: int, backend: str, device: int | None) -> None:
    """The worker's loop: a job in, its manifest line out, until the pipe closes."""
    _die_with_parent(parent)
    from app.batch.worker import release_all, run_job

    try:
        while (job := _receive(jobs_fd)) is not None:
            _send(results_fd, run_job(job, backend, device))  # type: ignore[arg-type]
    finally:
        release_all()


@dataclass
class _Worker:
    proc: subprocess.Popen
    jobs_fd: int
    results_fd: int
    slot: int  # which of the pool's places it holds: its device
    job: Job | None = None
    done: int = 0

    def stop(self) -> None:
        for fd in (self.jobs_fd, self.results_fd):
            with contextlib.suppress(OSError):
                os.close(fd)


def _how_it_died(proc: subprocess.Popen) -> str:
    code = proc.wait()
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exited with code {code}"


@dataclass
class WorkerPool:
    """``size`` worker processes rendering jobs one at a time (see the module docstring)."""

    size: int
    backend: str = "auto"
    devices: tuple[int, ...] = ()  # EGL devices, round-robin over the slots; () for none
    workers: list[_Worker] = field(default_factory=list)

    def _start(self, slot: int) -> _Worker:
        jobs_read, jobs_write = os.pipe()
        results_read, results_write = os.pipe()
        package_root = str(Path(__file__).resolve().parents[2])
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
        device = str(self.devices[slot % len(self.devices)]) if self.devices else "-"
        argv = [sys.executable, "-m", "app.batch.pool", "CHILD", str(jobs_read),
                str(results_write), str(os.getpid()), self.backend, device]  # fmt: skip
        proc = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, pass_fds=(jobs_read, results_write), env=env,
        )  # fmt: skip
        os.close(jobs_read)
        os.close(results_write)
        return _Worker(proc, jobs_write, results_read, slot)

    def run(self, jobs: list[Job]) -> Iterator[dict]:
        """Every job's manifest line, in the order they end."""
        pending = list(reversed(jobs))
        early_deaths = 0
        selector = selectors.DefaultSelector()
        try:
            for slot in range(min(self.size, len(jobs))):
                self.workers.append(self._start(slot))
            for w in self.workers:
                selector.register(w.results_fd, selectors.EVENT_READ, w)
            busy = 0
            for w in self.workers:
                busy += self._give(w, pending)
            while busy:
                for key, _ in selector.select():
                    w: _Worker = key.data
                    result = _receive(w.results_fd)
                    if result is not None:
                        yield result  # type: ignore[misc]
                        w.job, w.done = None, w.done + 1
                        early_deaths = 0
                        busy -= 1
                        busy += self._give(w, pending)
                        continue
                    # The worker died: its job alone fails; another takes its place.
                    selector.unregister(w.results_fd)
                    w.stop()
                    self.workers.remove(w)
                    busy -= 1
                    how = _how_it_died(w.proc)
                    early_deaths = early_deaths + 1 if w.done == 0 else 0
                    if w.job is not None:
                        yield lost(w.job, f"worker process {w.proc.pid} {how}")
                    if pending and early_deaths >= MAX_EARLY_DEATHS:
                        why = f"worker processes keep dying before a job ends (last: {how})"
                        while pending:
                            yield lost(pending.pop(), why)
                    if pending:
                        fresh = self._start(w.slot)
                        self.workers.append(fresh)
                        selector.register(fresh.results_fd, selectors.EVENT_READ, fresh)
                        busy += self._give(fresh, pending)
        finally:
            selector.close()
            self.close()

    def _give(self, w: _Worker, pending: list[Job]) -> int:
        """Hand ``w`` the next job (1), or nothing is left (0)."""
        if not pending:
            return 0
        w.job = pending.pop()
        with contextlib.suppress(OSError):  # it died already: its end of file comes through
            _send(w.jobs_fd, w.job)
        return 1

    def close(self) -> None:
        """End every worker: their job pipes close, so they leave their loops and exit;
        one that has not within five seconds is killed."""
        for w in self.workers:
            w.stop()
        for w in self.workers:
            try:
                w.proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                w.proc.kill()
                w.proc.wait()
        self.workers.clear()


def lost(job: Job, why: str) -> dict:
    """The manifest line of a job whose worker died under it (a crash in the driver, a
    signal, Dask's workers lost past its retries)."""
    error = " ".join(f"worker lost: {why}".split())
    line = {"job": job.id, "output": job.output, "seconds": 0.0, "status": "failed"}
    return {**line, "error": error, "device": None}


if __name__ == "__main__" and sys.argv[1:2] == ["CHILD"]:
    _child(
        int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5],
        None if sys.argv[6] == "-" else int(sys.argv[6]),
    )  # fmt: skip
