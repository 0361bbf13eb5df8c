"""One job rendered in a process that stays warm: its GL context, its shader cache and its
last ``Renderer`` live as long as the process (a spawned pool worker, a Dask worker, or
the ``pbs batch`` process itself with one worker).

An orbit frame or a sweep step of the scene the renderer already shows goes through
``Renderer.update``: a camera change compiles and uploads nothing, a material key rebuilds
only the material table (docs/architecture.md, "A renderer that changes"). Another scene
file, or another size, gets a new ``Renderer`` on the same context and shader cache, so a
program any earlier job compiled is reused.

``run_job`` never raises: every failure becomes a result with status ``"failed"`` and a
one-line message, so one bad job never stops the others. Its result names the EGL device
the process's context is on (``device``, as EGL reports it; None for OSMesa), so a run
over ``--devices`` shows where each job went.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from pathlib import Path

from app.batch.jobs import Job, load_source
from app.errors import InputError
from app.gl.context import GLContext, create_context
from app.gl.shaders import ShaderCache
from app.output import write_png
from app.render.renderer import Renderer
from app.scene.edits import edited
from app.scene.loader import LoadedScene
from app.scene.model import Camera


@dataclass
class _Warm:
    """The process's GL state, kept between jobs."""

    gl: GLContext
    shaders: ShaderCache
    renderer: Renderer | None = None
    base: LoadedScene | None = None  # the scene file as loaded, before any job's edit
    key: tuple[str, tuple[int, int] | None] | None = None  # (scene file, size) of renderer


# (backend, EGL device) -> state; one entry per process in practice.
_WARM: dict[tuple[str, int | None], _Warm] = {}


def _warm(backend: str, device: int | None) -> _Warm:
    if (backend, device) not in _WARM:
        gl = create_context(backend, device, "--devices")  # type: ignore[arg-type]
        _WARM[backend, device] = _Warm(gl, ShaderCache(gl.ctx))
    return _WARM[backend, device]


def release_all() -> None:
    """Release every renderer, shader cache and context of this process."""
    for warm in _WARM.values():
        if warm.renderer is not None:
            warm.renderer.release()
        warm.shaders.release()
        warm.gl.release()
    _WARM.clear()


def _renderer(warm: _Warm, job: Job) -> tuple[Renderer, LoadedScene]:
    """The renderer for the job's scene file and size, built only when either changed."""
    key = (job.scene, job.size)
    if warm.key != key or warm.renderer is None:
        if warm.renderer is not None:
            warm.renderer.release()
            warm.renderer, warm.key = None, None
        warm.base = load_source(job.scene, job.policy, job.look, job.size)
        warm.renderer = Renderer(warm.gl, warm.base, job.size, shaders=warm.shaders)
        warm.key = key
    return warm.renderer, warm.base


def _show(renderer: Renderer, base: LoadedScene, job: Job) -> None:
    """Make the renderer show the job's scene: the base with its camera or key edit."""
    scene = base.scene
    if job.camera is not None:
        scene = scene.model_copy(update={"camera": Camera.model_validate(job.camera)})
    elif job.key is not None:
        scene = edited(base, {job.key: job.value}, "sweep").scene
    if job.background is not None:  # the job file's background, over the scene's
        settings = scene.render.model_copy(update={"background": job.background})
        scene = scene.model_copy(update={"render": settings})
    renderer.update(scene)


def _forget(backend: str, device: int | None) -> None:
    """Drop the renderer after a failure (it may be half updated); the context stays."""
    warm = _WARM.get((backend, device))
    if warm is not None and warm.renderer is not None:
        with contextlib.suppress(Exception):
            warm.renderer.release()
        warm.renderer, warm.key = None, None


def _one_line(exc: BaseException) -> str:
    text = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def run_job(job: Job, backend: str = "auto", device: int | None = None) -> dict:
    """Render ``job`` into its output PNG (written atomically) on the EGL ``device``
    (None: ``PBS_EGL_DEVICE``, else EGL's first); its manifest line."""
    start = time.perf_counter()
    warm = None
    try:
        warm = _warm(backend, device)
        renderer, base = _renderer(warm, job)
        _show(renderer, base, job)
        renderer.render()
        write_png(Path(job.output), renderer.read_image())  # RGBA: a transparent background
        status, error = "ok", None
    except Exception as exc:  # a failed job is a manifest line, never the batch's end
        status, error = "failed", _one_line(exc)
        _forget(backend, device)
    return {
        "job": job.id,
        "output": job.output,
        "seconds": round(time.perf_counter() - start, 4),
        "status": status,
        "error": error,
        "device": None if warm is None else warm.gl.device,
    }


def run_dask_job(job: Job, backend: str, devices: dict[str, int]) -> dict:
    """``run_job`` on a Dask worker, on the device ``devices`` gives its address (the
    round-robin of ``pbs batch --devices``); a worker that joined after the run started
    takes the first listed device."""
    from distributed import get_worker

    device = devices.get(get_worker().address, next(iter(devices.values())))
    return run_job(job, backend, device)
