"""Suite ``batch`` of ``pbs bench``: images per second of an orbit, four ways.

The orbit: ``Settings.batch_frames`` frames (100 full, 20 quick) at ``batch_size``
(512x512) of a helmet-sized mesh (suites.api_mesh_scene: an 81,920-triangle icosphere as
a ``.glb`` on a floor, one directional and one point light), the cameras that
``pbs batch``'s orbit job computes (app/batch/jobs.py). The ways, each writing every
image as a PNG (the encoding is part of what a user pays):

- ``pbs batch, 1 worker``: ``pbs batch`` in its own process (interpreter, context,
  compiles, uploads, then each frame through ``Renderer.update``);
- ``pbs batch, N workers``: the same with ``--workers N``, N the usable cores, at most 4
  (skipped on a one-core machine);
- ``CLI loop``: one ``pbs render`` process per frame (``batch_cli_frames`` of the orbit's
  frames, each with its own scene file holding that frame's camera): slow, so fewer
  frames, reported per image;
- ``pyrender``: pyrender in one child process (app/bench/pyrender_child.py's orbit
  request): the same scene file, triangles, cameras and lights, each frame rendered,
  read back and written with the same PNG writer. Without pyrender the row says why.

Every way's "whole run" is timed from spawning its process(es) to their exit, so the
ratios compare what a user waits for. The ways run in ``batch_rounds`` rounds with the
order rotated every round (as timing.time_interleaved does for frames), so a change of the
machine's load falls on all of them; a row's ``images_per_s`` is the median over rounds
with the min and max beside it. ``steady_ms_median`` is the median time of one image
inside a warm process (the manifest's job seconds; pyrender's per-frame times). The
ratios (report.batch_ratios) are computed from the rows of one run and stored in them.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from app.batch.jobs import plan_jobs
from app.batch.run import MANIFEST, valid_output
from app.bench.context import Context, api_mesh_scene, make_row
from app.bench.report import BATCH_CLI, BATCH_ONE, BATCH_PYRENDER, batch_ratios
from app.bench.startup import repo_pythonpath
from app.render.compare import toml_value

MAX_WORKERS = 4
MESH_CASE = "icosphere mesh (.glb)"
PYRENDER_MISSING = "pyrender not installed"


def batch_workers() -> int:
    """N of the N-worker way: the cores this process may use, at most ``MAX_WORKERS``."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_WORKERS))


def scene_text(data: dict) -> str:
    """A scene dictionary as a TOML scene file: each top-level key one inline value."""
    return "".join(f"{key} = {toml_value(value)}\n" for key, value in data.items())


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = repo_pythonpath(env)  # the children import this checkout's app
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    return env


def _spawn(args: list[str], stdin: str | None = None) -> tuple[float, str]:
    """Seconds from spawning ``python ARGS`` to its exit, and its stdout; raises on failure."""
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, *args], input=stdin, capture_output=True, text=True, env=_env(),
        timeout=1800, check=False,
    )  # fmt: skip
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        tail = " ".join(proc.stderr.strip().splitlines()[-1:])
        raise RuntimeError(f"{' '.join(args[:3])}: exit {proc.returncode}: {tail}")
    return seconds, proc.stdout


class _Orbit:
    """The orbit's files in ``folder``: scene, job file, per-frame scenes for the CLI."""

    def __init__(self, ctx: Context, folder: Path) -> None:
        s = ctx.settings
        self.folder = folder
        self.size = s.batch_size
        self.frames = s.batch_frames
        self.data = api_mesh_scene(folder, s.batch_subdivisions)
        self.scene = folder / "orbit.toml"
        self.scene.write_text(scene_text(self.data), encoding="utf-8")
        self.jobs = folder / "jobs.toml"
        w, h = self.size
        self.jobs.write_text(
            f'scene = "orbit.toml"\nsize = "{w}x{h}"\norbit = {{ frames = {self.frames} }}\n',
            encoding="utf-8",
        )
        self.cameras = [job.camera for job in plan_jobs(self.jobs, folder / "plan").jobs]
        self.cli_scenes = []
        for k in range(s.batch_cli_frames):
            path = folder / f"cli-frame-{k:04d}.toml"
            camera = {**self.data["camera"], "position": self.cameras[k]["position"]}
            path.write_text(scene_text({**self.data, "camera": camera}), encoding="utf-8")
            self.cli_scenes.append(path)


def _valid(paths: list[Path], size: tuple[int, int]) -> int:
    return sum(valid_output(p, size) for p in paths)


def _pbs_batch(orbit: _Orbit, workers: int, tag: str) -> dict:
    out = orbit.folder / f"batch-{workers}-{tag}"
    seconds, _ = _spawn(
        ["-m", "app", "batch", str(orbit.jobs), "-o", str(out), "--workers", str(workers),
         "--no-resume", "-q"]
    )  # fmt: skip
    lines = [json.loads(x) for x in (out / MANIFEST).read_text(encoding="utf-8").splitlines()]
    bad = [x for x in lines if x["status"] != "ok"]
    if bad:
        raise RuntimeError(f"pbs batch: {len(bad)} jobs failed: {bad[0]['error']}")
    outputs = [Path(x["output"]) for x in lines]
    return {
        "seconds": seconds,
        "images": len(lines),
        "steady_ms": [x["seconds"] * 1e3 for x in lines],
        "valid": _valid(outputs, orbit.size),
    }


def _cli_loop(orbit: _Orbit, tag: str) -> dict:
    w, h = orbit.size
    times, outputs = [], []
    for k, scene in enumerate(orbit.cli_scenes):
        out = orbit.folder / f"cli-{tag}-{k:04d}.png"
        seconds, _ = _spawn(["-m", "app", "render", str(scene), "-o", str(out),
                             "--size", f"{w}x{h}", "-q"])  # fmt: skip
        times.append(seconds)
        outputs.append(out)
    return {"seconds": sum(times), "images": len(times), "per_image_s": times,
            "valid": _valid(outputs, orbit.size)}  # fmt: skip


def _pyrender(orbit: _Orbit, tag: str) -> dict:
    out = orbit.folder / f"pyrender-{tag}"
    out.mkdir()
    request = {"scene_file": str(orbit.scene), "size": list(orbit.size),
               "cameras": orbit.cameras, "out": str(out)}  # fmt: skip
    seconds, stdout = _spawn(["-m", "app.bench.pyrender_child"], json.dumps(request))
    lines = [line for line in stdout.splitlines() if line.startswith("{")]
    result = json.loads(lines[-1]) if lines else {"ok": False, "why": "no result"}
    if not result.get("ok"):
        raise RuntimeError(f"pyrender: {result.get('why')}")
    outputs = sorted(out.glob("*.png"))
    return {"seconds": seconds, "images": len(result["ms"]), "steady_ms": result["ms"],
            "valid": _valid(outputs, orbit.size), "pyrender": result}  # fmt: skip


def _row(orbit: _Orbit, variant: str, runs: list[dict], timer: str) -> dict:
    """One way's row from its rounds: per-image ms of each round's whole run, images/s."""
    per_image = [r["seconds"] * 1e3 / r["images"] for r in runs]
    rates = [r["images"] / r["seconds"] for r in runs]
    steady = [ms for r in runs for ms in r.get("steady_ms", [])]
    if not steady:  # the CLI loop: every image is a whole process
        steady = [s * 1e3 for r in runs for s in r["per_image_s"]]
    extra = {k: v for k, v in runs[-1].items() if k == "pyrender"}
    return make_row(
        "batch", f"orbit {orbit.frames} frames, {MESH_CASE}", variant, orbit.size,
        len(orbit.data["lights"]), None,
        ms_median=statistics.median(per_image), ms_min=min(per_image), ms_max=max(per_image),
        frames=sum(r["images"] for r in runs), rounds=len(runs),
        images_per_round=runs[0]["images"], orbit_frames=orbit.frames,
        images_per_s=statistics.median(rates), images_per_s_min=min(rates),
        images_per_s_max=max(rates), seconds_per_round=[r["seconds"] for r in runs],
        steady_ms_median=statistics.median(steady),
        images_valid=sum(r["valid"] for r in runs), timer=timer, **extra,
    )  # fmt: skip


def _missing(orbit: _Orbit, variant: str, why: str) -> dict:
    """The row of a way that could not run, saying why."""
    return make_row(
        "batch", f"orbit {orbit.frames} frames, {MESH_CASE}", variant, orbit.size,
        len(orbit.data["lights"]), None, orbit_frames=orbit.frames, images_per_s=None,
        not_measured=why,
    )  # fmt: skip


def pyrender_why(ctx: Context) -> str:
    """Why the pyrender way is not measured, in the words the rows use."""
    why = ctx.pyrender_why or "pyrender comparison skipped"
    return f"{PYRENDER_MISSING} ({why})" if "No module named" in why else why


def batch_tasks(pyrender: bool, rounds: int, workers: int) -> int:
    """Progress-bar tasks: one per way and round."""
    return rounds * (2 + (workers > 1) + pyrender)


def run_batch(ctx: Context, folder: Path | None = None) -> None:
    """Suite ``batch`` (module docstring); the outputs stay in ``folder`` if given."""
    if folder is None:
        with tempfile.TemporaryDirectory(prefix="pbs-bench-batch-") as tmp:
            run_batch(ctx, Path(tmp))
        return
    s = ctx.settings
    orbit = _Orbit(ctx, folder)
    n = batch_workers()
    whole = "process spawn to exit, every image written as PNG"
    ways: dict[str, tuple] = {BATCH_ONE: (lambda t: _pbs_batch(orbit, 1, t), whole)}
    if n > 1:
        ways[f"pbs batch, {n} workers"] = (lambda t: _pbs_batch(orbit, n, t), whole)
    ways[BATCH_CLI] = (
        lambda t: _cli_loop(orbit, t),
        f"{whole}, one process per image ({s.batch_cli_frames} of the orbit's frames)",
    )
    if ctx.pyrender:
        ways[BATCH_PYRENDER] = (lambda t: _pyrender(orbit, t), f"{whole} (one child)")
    order = list(ways)
    runs: dict[str, list[dict]] = {v: [] for v in order}
    failed: dict[str, str] = {}  # a way that failed is left out of later rounds
    for r in range(s.batch_rounds):
        shift = r % len(order)
        for variant in order[shift:] + order[:shift]:
            if variant in failed:
                continue
            ctx.progress.start(f"batch: {variant}, round {r + 1}/{s.batch_rounds}")
            try:
                runs[variant].append(ways[variant][0](f"r{r}"))
            except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
                failed[variant] = f"failed: {exc}"
                ctx.notes.append(f"batch: {variant} {failed[variant]}")
            ctx.progress.done()
    rows = [
        _missing(orbit, v, failed[v]) if v in failed else _row(orbit, v, runs[v], ways[v][1])
        for v in order
    ]
    if n == 1:
        rows.insert(1, _missing(orbit, "pbs batch, N workers", "one usable core"))
    if not ctx.pyrender:
        rows.append(_missing(orbit, BATCH_PYRENDER, pyrender_why(ctx)))
    rows[0]["ratios"] = batch_ratios(rows)
    ctx.rows.extend(rows)
