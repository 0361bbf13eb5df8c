"""Suite ``viewer``: how long an input waits for its new image in the desktop viewer.

The viewer runs in a child process (``python -m app.bench.viewer REQUEST``) with its own
window, on the machine's display or, where there is none, on a private Xvfb: the bench's
headless EGL context and a GLX window context do not share a thread well, and a child
measures a fresh process as a user would start it. Each interaction is timed from the
call that delivers the input to the moment its image has been drawn into the window and
swapped, the GL finished (``ctx.finish``):

* ``orbit``: a 12-pixel drag, rendered at the preview size (1/PREVIEW_SCALE per side);
* ``roughness``: a material value dragged on a slider, also a preview;
* ``refine``: the full-size frame the viewer draws once input stops;
* ``new model``: an NDF never compiled before, from the edit to the "compiling..."
  frame (``notice``) and to the image with the new model (``compiled``).

And what an idle window costs: ``idle``, the process's CPU time (every thread: Python, the
driver's) over ``IDLE_SECONDS`` of the interactive loop (``Viewer.run``) with no input, as a
percentage of one core, and the frames drawn meanwhile; the target is ``IDLE_CPU_MAX``.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ORBIT_MOVES = 40  # preview frames timed per interaction
NEW_MODELS = ("beckmann", "blinn_phong", "gtr")  # NDFs the showcase does not use
IDLE_SECONDS = 10.0  # how long the idle window is watched
IDLE_CPU_MAX = 2.0  # percent of one core an idle viewer may take


def _finish(v) -> None:
    v.ctx.finish()


def measure(size: tuple[int, int], moves: int) -> dict[str, list[float]]:
    """The child's work: milliseconds per interaction, in a window of ``size``."""
    from app.resources import scenes_dir
    from app.viewer.window import REFINE_AFTER, Viewer

    v = Viewer(scenes_dir() / "showcase.toml", size, vsync=False)
    out: dict[str, list[float]] = {k: [] for k in ("orbit", "roughness", "refine")}
    out.update({"new model notice": [], "new model compiled": []})
    try:
        v.settle()
        for _ in range(moves):
            start = time.perf_counter()
            v.orbit(12.0, 0.0)
            v.step()
            _finish(v)
            out["orbit"].append((time.perf_counter() - start) * 1e3)
        for i in range(moves):
            start = time.perf_counter()
            v.edit({"materials.gold.roughness": 0.2 + 0.01 * (i % 20)})
            v.step()
            _finish(v)
            out["roughness"].append((time.perf_counter() - start) * 1e3)
        for _ in range(5):
            v.step()
            time.sleep(REFINE_AFTER)
            v.touch()
            v.step()  # a preview frame first, as after any input
            time.sleep(REFINE_AFTER + 0.01)
            start = time.perf_counter()
            v.step()  # input has stopped: the full-size frame
            _finish(v)
            out["refine"].append((time.perf_counter() - start) * 1e3)
        for ndf in NEW_MODELS:
            start = time.perf_counter()
            v.edit({"materials.gold.ndf": ndf})
            v.step()  # the last image with the notice
            _finish(v)
            out["new model notice"].append((time.perf_counter() - start) * 1e3)
            v.step()  # the edit, its compile and the image
            _finish(v)
            out["new model compiled"].append((time.perf_counter() - start) * 1e3)
        v.settle()
        v.run(1.0)  # the panels' last frames after the input above
        frames, cpu, wall = v.frames, time.process_time(), time.perf_counter()
        v.run(IDLE_SECONDS)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        out["idle cpu percent"] = [100.0 * cpu / wall]
        out["idle frames"] = [float(v.frames - frames)]
    finally:
        v.close()
    return out


def run_child(size: tuple[int, int], moves: int = ORBIT_MOVES) -> dict:
    """Measure in a child process, on a private Xvfb where there is no display;
    {"ms": {interaction: [ms, ...]}} or {"error": text}."""
    from app.viewer.xvfb import xvfb

    request = json.dumps({"size": list(size), "moves": moves})
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parent.parent.parent)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))

    def child() -> dict:
        proc = subprocess.run(
            [sys.executable, "-m", "app.bench.viewer", request],
            capture_output=True, text=True, env={**env, "DISPLAY": os.environ["DISPLAY"]},
            timeout=600,
        )  # fmt: skip
        lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
        if proc.returncode != 0 or not lines:
            return {"error": proc.stderr.strip().splitlines()[-1:] or ["no output"]}
        return {"ms": json.loads(lines[-1])}

    if os.environ.get("DISPLAY"):
        return child()
    try:
        with xvfb():
            return child()
    except RuntimeError as exc:
        return {"error": str(exc)}


def summary_ms(values: list[float]) -> dict[str, float]:
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return {
        "ms_median": statistics.median(ordered),
        "ms_min": ordered[0],
        "ms_max": ordered[-1],
        "ms_p95": p95,
    }


if __name__ == "__main__":
    args = json.loads(sys.argv[1])
    result = measure(tuple(args["size"]), int(args["moves"]))
    print(json.dumps(result))
