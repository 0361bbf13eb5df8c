"""Running a plan's jobs: resume, workers (in-process, worker processes or Dask), progress
and ``manifest.jsonl``, under a lock on the output folder.

Worker processes (app/batch/pool.py) are started with ``subprocess``, never forked: a GL
context (EGL or OSMesa) must never cross a ``fork``. Each makes one context on its first
job and keeps it, with its renderer, for every later job (app/batch/worker.py). Jobs are
handed out one at a time, so a slow job does not hold a queue of others behind it, and a
worker that dies fails only the job it held.

One run at a time writes into a folder: ``.pbs-batch.lock`` in it is held (``flock``) for
the run, so a second run into the same folder exits 2 at once instead of interleaving its
manifest with the first's; the kernel releases it however the holder ends. A run first
removes the temporary files (``.NAME.*.png``) that a killed run left beside its outputs.

``manifest.jsonl`` in the output folder gets one JSON line per job as it ends (``job``,
``output``, ``seconds``, ``status``: ``ok``, ``skipped`` or ``failed``, ``error``,
``device``: the EGL device the job rendered on), each
written by one ``write`` of an ``O_APPEND`` descriptor, so a run that is killed leaves
whole lines of the jobs that ended. It is written anew by every run; ``skipped`` marks an
output a previous run already wrote whole.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from PIL import Image

from app.batch.jobs import Job, Plan
from app.batch.pool import WorkerPool, lost
from app.batch.worker import release_all, run_dask_job, run_job
from app.errors import InputError
from app.progress import Progress

MANIFEST = "manifest.jsonl"
LOCK = ".pbs-batch.lock"
DASK_HINT = "needs Dask distributed (pip install 'pbs-lab[distributed]')"
SCHEDULER_TIMEOUT = 10.0  # seconds to reach a --scheduler before the run is refused


def valid_output(path: Path, expected: tuple[int, int] | None, mode: str | None = None) -> bool:
    """Whether ``path`` is a PNG that decodes whole (a truncated file does not) and has
    the expected (width, height) and PIL mode ("RGB", or "RGBA" for a transparent
    background) where those are known."""
    try:
        with Image.open(path) as image:
            if image.format != "PNG" or (mode is not None and image.mode != mode):
                return False
            image.load()  # decodes every row: a truncated file raises here
            return expected is None or image.size == tuple(expected)
    except (OSError, SyntaxError, ValueError):  # PIL's ways of saying "not an image"
        return False


def _mode(job: Job) -> str | None:
    """The PNG mode a job writes where its job file sets the background (a scene's own
    ``render.background`` is read only when the job renders)."""
    if job.background is None:
        return None
    return "RGBA" if job.background == "transparent" else "RGB"


def _in_process(jobs: list[Job], backend: str, devices: tuple[int, ...]) -> Iterator[dict]:
    try:
        for job in jobs:
            yield run_job(job, backend, devices[0] if devices else None)
    finally:
        release_all()


def _processes(
    jobs: list[Job], workers: int, backend: str, devices: tuple[int, ...]
) -> Iterator[dict]:
    yield from WorkerPool(workers, backend, devices).run(jobs)


def dask_client(scheduler: str | None, local: int | None, option: str) -> object:
    """A ``distributed.Client`` on ``scheduler``'s address, or on a new LocalCluster of
    ``local`` worker processes with one thread each (one GL context per process, used
    from that one thread). Without Dask installed: an ``InputError`` naming ``option``."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(option, "", DASK_HINT) from None
    if scheduler is not None:
        try:
            return Client(scheduler, timeout=SCHEDULER_TIMEOUT)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(
                option, "", f"cannot reach the scheduler at {scheduler} ({why[:160]})"
            ) from None
    cluster = LocalCluster(
        n_workers=local, threads_per_worker=1, processes=True, dashboard_address=None
    )
    return Client(cluster)


def _dask(
    jobs: list[Job], client: object, backend: str, devices: tuple[int, ...]
) -> Iterator[dict]:
    from distributed import as_completed as dask_completed

    if devices:  # worker k (by address, sorted) on devices[k % len(devices)]
        workers = sorted(client.scheduler_info()["workers"])  # type: ignore[attr-defined]
        by_worker = {a: devices[k % len(devices)] for k, a in enumerate(workers)}
        futures = client.map(  # type: ignore[attr-defined]
            run_dask_job, jobs, backend=backend, devices=by_worker or {"": devices[0]},
            pure=False,
        )  # fmt: skip
    else:
        futures = client.map(run_job, jobs, backend=backend, pure=False)  # type: ignore[attr-defined]
    by_key = {f.key: job for f, job in zip(futures, jobs, strict=True)}
    for future in dask_completed(futures):
        try:
            yield future.result()
        except Exception as exc:  # a worker lost past Dask's retries
            yield lost(by_key[future.key], f"{type(exc).__name__}: {exc}")


@contextlib.contextmanager
def folder_lock(out: Path) -> Iterator[None]:
    """Hold ``out/.pbs-batch.lock`` for the block; an ``InputError`` naming the folder
    where another run holds it."""
    fd = os.open(out / LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            raise InputError(
                str(out), "-o", f"another pbs batch (pid {holder}) is writing into this folder"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def remove_stale(out: Path, jobs: list[Job]) -> int:
    """Remove the temporary files a killed run left for these jobs' outputs (app/output.py
    writes ``.NAME.<random>.png`` and renames it); how many there were."""
    removed = 0
    for job in jobs:
        output = Path(job.output)
        if output.parent.resolve() != out.resolve():
            continue
        for stale in out.glob(f".{output.name}.*{output.suffix}"):
            with contextlib.suppress(OSError):
                stale.unlink()
                removed += 1
    return removed


def run_batch(
    plan: Plan,
    out: Path,
    workers: int = 1,
    backend: str = "auto",
    resume: bool = True,
    progress: Progress | None = None,
    client: object | None = None,
    on_result: Callable[[dict], None] | None = None,
    devices: tuple[int, ...] = (),
) -> list[dict]:
    """Render ``plan`` into ``out``; the manifest lines, in the order the jobs ended.

    With ``resume``, a job whose output is already a valid PNG of the expected size is
    not rendered again (status ``skipped``). ``workers`` > 1 starts that many worker
    processes; ``client`` (a ``distributed.Client``) runs the jobs on its workers instead.
    ``devices``: EGL device indexes, spread round-robin over the workers (one process:
    the first); () leaves each worker to ``PBS_EGL_DEVICE`` or EGL's first device.
    The folder is locked for the run (``folder_lock``) and cleared of stale temporary
    files first (``remove_stale``).
    """
    out.mkdir(parents=True, exist_ok=True)
    results: list[dict] = []
    todo: list[Job] = []
    with folder_lock(out):
        remove_stale(out, plan.jobs)
        fd = os.open(
            out / MANIFEST, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND | os.O_CLOEXEC,
            0o644,
        )  # fmt: skip
        try:

            def record(line: dict) -> None:
                os.write(fd, (json.dumps(line) + "\n").encode())  # one write: a whole line
                results.append(line)
                if progress is not None:
                    timed = line["status"] != "skipped"
                    progress.job(f"{line['job']} {line['status']}", line["seconds"], timed)
                if on_result is not None:
                    on_result(line)

            for job in plan.jobs:
                if resume and valid_output(Path(job.output), job.expected, _mode(job)):
                    line = {"job": job.id, "output": job.output, "seconds": 0.0}
                    record({**line, "status": "skipped", "error": None, "device": None})
                else:
                    todo.append(job)
            if client is not None:
                stream = _dask(todo, client, backend, devices)
            elif workers > 1 and len(todo) > 1:
                stream = _processes(todo, min(workers, len(todo)), backend, devices)
            else:
                stream = _in_process(todo, backend, devices)
            for line in stream:
                record(line)
        finally:
            os.close(fd)
    return results
