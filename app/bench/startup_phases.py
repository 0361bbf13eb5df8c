"""Where a cold start's time goes: the steps of ``pbs render`` in a fresh process.

Run by app/bench/startup.py ``startup_phases`` as ``python -c PHASES_BOOT REQUEST``: the
bootstrap stamps the interpreter's start and the CLI's imports (``import app.cli``, as
``pbs`` makes them; from a child process, as the bench runs ``pbs`` itself, not an import
of this layer), then calls ``main``, which does what app/cli.py ``cmd_render`` does, in the
same order, and stamps each step: reading and validating the scene (with the scene
layer's imports), the GL stack's imports, the EGL context, ``Renderer()`` (the frame's
parts and material table, uploads, the programs: compiling and linking them is timed
apart, as ``ShaderCache`` builds them), the first frame (``render()`` to a ``glFinish``:
llvmpipe turns each program into machine code at its first draw), the read-back and the
PNG (encoding and writing). Each step has its wall time (the first from the launcher's
spawn, whose wall-clock time comes in the request) and the process's CPU time (all
threads: llvmpipe's rasterisers too), which a shared machine's load moves less. The
request is {"t0": spawn time (time.time()), "scene": path, "out": png path, "size":
[w, h] or null}; the answer one JSON line {"phases": [[name, wall_s, cpu_s], ...],
"programs_s": ..., "programs": n}.

It is the bench's, not the CLI's: the CLI has no timing hooks, and the two must draw the
same steps (tests/test_bench_startup_phases.py checks the PNG is the CLI's, byte for
byte).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

_STAMPS: list[tuple[str, float, float]] = []


def _stamp(name: str) -> None:
    _STAMPS.append((name, time.time(), time.process_time()))


def run(request: dict, stamps: list[tuple[str, float, float]]) -> dict:
    """The steps of ``pbs render`` after the bootstrap's ``stamps`` (module docstring),
    with a stamp after each."""
    _STAMPS[:] = stamps
    from app.scene.sources import scene_from

    size = tuple(request["size"]) if request.get("size") else None
    loaded = scene_from(Path(request["scene"]), size=size)
    _stamp("scene read and validated (its imports included)")
    from app.gl import shaders
    from app.render.renderer import Renderer

    _stamp("imports: GL and the renderer")
    from app.gl.context import create_context

    gl = create_context("auto")
    _stamp("EGL context")
    built = {"s": 0.0, "n": 0}
    program = shaders.ShaderCache.program

    def timed(self, *args, **kwargs):  # compile + link, where the cache builds one
        before = len(self._programs)
        t = time.perf_counter()
        prog = program(self, *args, **kwargs)
        if len(self._programs) > before:
            built["s"] += time.perf_counter() - t
            built["n"] += 1
        return prog

    shaders.ShaderCache.program = timed
    renderer = Renderer(gl, loaded, size)
    _stamp("Renderer(): parts, material table, uploads, programs")
    renderer.render()
    gl.ctx.finish()
    _stamp("first frame (llvmpipe's machine code at each first draw)")
    image = renderer.read_image()
    _stamp("read-back")
    renderer.release()
    from app.output import write_png

    write_png(Path(request["out"]), image)
    _stamp("PNG encoded and written")
    gl.release()
    t0 = float(request["t0"])
    phases, last_t, last_cpu = [], t0, 0.0
    for name, t, cpu in _STAMPS:
        phases.append([name, t - last_t, cpu - last_cpu])
        last_t, last_cpu = t, cpu
    return {"phases": phases, "programs_s": built["s"], "programs": built["n"]}


def main(stamps: list[tuple[str, float, float]]) -> None:
    """The bootstrap's entry: the request from ``sys.argv[1]``, the answer on stdout."""
    print(json.dumps(run(json.loads(sys.argv[1]), stamps)))
