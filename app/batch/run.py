"""Running a plan's jobs: resume, workers (in-process, spawned processes or Dask), progress
and ``manifest.jsonl``.

Processes are started with multiprocessing's ``spawn`` method: a GL context (EGL or
OSMesa) must never cross a ``fork``. Each worker process makes one context on its first job
and keeps it, with its renderer, for every later job (app/batch/worker.py). Jobs are handed
out one at a time, so a slow job does not hold a queue of others behind it.

``manifest.jsonl`` in the output folder gets one JSON line per job as it ends (``job``,
``output``, ``seconds``, ``status``: ``ok``, ``skipped`` or ``failed``, ``error``): a run
that is killed leaves the lines of the jobs that ended. It is written anew by every run;
``skipped`` marks an output a previous run already wrote whole.
"""

from __future__ import annotations

import json
import multiprocessing
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from PIL import Image

from app.batch.jobs import Job, Plan
from app.batch.worker import release_all, run_job
from app.errors import InputError
from app.progress import Progress

MANIFEST = "manifest.jsonl"
DASK_HINT = "needs Dask distributed (pip install 'pbs-lab[distributed]')"


def valid_output(path: Path, expected: tuple[int, int] | None) -> bool:
    """Whether ``path`` is a PNG that decodes whole (a truncated file does not) and has
    the expected (width, height) where that is known."""
    try:
        with Image.open(path) as image:
            if image.format != "PNG":
                return False
            image.load()  # decodes every row: a truncated file raises here
            return expected is None or image.size == tuple(expected)
    except (OSError, SyntaxError, ValueError):  # PIL's ways of saying "not an image"
        return False


def _in_process(jobs: list[Job], backend: str) -> Iterator[dict]:
    try:
        for job in jobs:
            yield run_job(job, backend)
    finally:
        release_all()


def _failed(job: Job, exc: BaseException) -> dict:
    """The manifest line of a job whose worker died under it (a crash in the driver)."""
    error = " ".join(f"worker lost: {type(exc).__name__}: {exc}".split())
    return {"job": job.id, "output": job.output, "seconds": 0.0, "status": "failed", "error": error}


def _processes(jobs: list[Job], workers: int, backend: str) -> Iterator[dict]:
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=spawn) as pool:
        futures = {pool.submit(run_job, job, backend): job for job in jobs}
        for future in as_completed(futures):
            try:
                yield future.result()
            except Exception as exc:  # BrokenProcessPool: a worker died (not a job error)
                yield _failed(futures[future], exc)


def dask_client(scheduler: str | None, local: int | None, option: str) -> object:
    """A ``distributed.Client`` on ``scheduler``'s address, or on a new LocalCluster of
    ``local`` worker processes with one thread each (one GL context per process, used
    from that one thread). Without Dask installed: an ``InputError`` naming ``option``."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(option, "", DASK_HINT) from None
    if scheduler is not None:
        return Client(scheduler)
    cluster = LocalCluster(
        n_workers=local, threads_per_worker=1, processes=True, dashboard_address=None
    )
    return Client(cluster)


def _dask(jobs: list[Job], client: object, backend: str) -> Iterator[dict]:
    from distributed import as_completed as dask_completed

    futures = client.map(run_job, jobs, backend=backend, pure=False)  # type: ignore[attr-defined]
    by_key = {f.key: job for f, job in zip(futures, jobs, strict=True)}
    for future in dask_completed(futures):
        try:
            yield future.result()
        except Exception as exc:  # a worker lost past Dask's retries
            yield _failed(by_key[future.key], exc)


def run_batch(
    plan: Plan,
    out: Path,
    workers: int = 1,
    backend: str = "auto",
    resume: bool = True,
    progress: Progress | None = None,
    client: object | None = None,
    on_result: Callable[[dict], None] | None = None,
) -> list[dict]:
    """Render ``plan`` into ``out``; the manifest lines, in the order the jobs ended.

    With ``resume``, a job whose output is already a valid PNG of the expected size is
    not rendered again (status ``skipped``). ``workers`` > 1 spawns that many processes;
    ``client`` (a ``distributed.Client``) runs the jobs on its workers instead.
    """
    out.mkdir(parents=True, exist_ok=True)
    results: list[dict] = []
    todo: list[Job] = []
    with (out / MANIFEST).open("w", encoding="utf-8") as manifest:

        def record(line: dict) -> None:
            manifest.write(json.dumps(line) + "\n")
            manifest.flush()
            results.append(line)
            if progress is not None:
                progress.start(f"{line['job']} {line['status']}")
                progress.done()
            if on_result is not None:
                on_result(line)

        for job in plan.jobs:
            if resume and valid_output(Path(job.output), job.expected):
                line = {"job": job.id, "output": job.output, "seconds": 0.0}
                record({**line, "status": "skipped", "error": None})
            else:
                todo.append(job)
        if client is not None:
            stream = _dask(todo, client, backend)
        elif workers > 1 and len(todo) > 1:
            stream = _processes(todo, min(workers, len(todo)), backend)
        else:
            stream = _in_process(todo, backend)
        for line in stream:
            record(line)
    return results
