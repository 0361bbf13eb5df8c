"""Batch throughput: images per second of an orbit, ``pbs batch`` against the alternatives.

``python -m app.bench.batch [--frames 100] [--size 512x512] [--workers 2] [--cli-runs 3]``
renders an orbit of the showcase (``--frames`` frames at ``--size``) and prints one JSON
object with images per second, all from one run so that their ratios share the machine's
state:

- ``batch_1``: ``pbs batch`` with one worker (in its own process: context, renderer,
  every frame through ``Renderer.update``; process start included);
- ``batch_N``: the same with ``--workers N`` spawned processes;
- ``cli_loop``: a shell loop of ``pbs render``, timed over ``--cli-runs`` runs and
  extrapolated to ``--frames`` (each run pays interpreter start, context, compile and
  upload; the camera does not change its cost, so the scene's own camera is rendered);
- ``pyrender``: pyrender on the same triangles in-process (app/bench/pyrender_child.py),
  its median frame time of a fixed camera as images per second (a pose change costs
  pyrender nothing measurable); recorded as unavailable, with why, without the ``bench``
  extra.

Every image is written to a PNG in the batch runs and the CLI loop (the PNG encoding is
part of the cost a user pays); pyrender's frames are read back into numpy only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from app.resources import scenes_dir


def _pbs(args: list[str]) -> float:
    """Seconds of ``python -m app ARGS`` (process start to exit); raises on failure."""
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "app", *args], capture_output=True, text=True, check=False
    )
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"pbs {' '.join(args)}: exit {proc.returncode}: {proc.stderr[-400:]}")
    return seconds


def _batch(folder: Path, jobs: Path, workers: int, frames: int) -> dict:
    out = folder / f"batch-{workers}"
    seconds = _pbs(["batch", str(jobs), "-o", str(out), "--workers", str(workers), "-q"])
    return {"seconds": seconds, "images": frames, "images_per_s": frames / seconds}


def _cli_loop(folder: Path, size: str, runs: int, frames: int) -> dict:
    times = [
        _pbs(["render", "showcase", "-o", str(folder / f"cli-{i}.png"), "--size", size, "-q"])
        for i in range(runs)
    ]
    per_image = sum(times) / len(times)
    return {
        "seconds_per_image": times,
        "images_per_s": 1.0 / per_image,
        "extrapolated_seconds": per_image * frames,
        "note": f"{runs} runs timed, extrapolated to {frames}",
    }


def _pyrender(size: tuple[int, int], frames: int) -> dict:
    import tomllib

    data = tomllib.loads((scenes_dir() / "showcase.toml").read_text(encoding="utf-8"))
    request = {"scene": data, "size": list(size), "warmup": 3, "min_frames": frames,
               "max_frames": frames, "seconds": 60.0}  # fmt: skip
    proc = subprocess.run(
        [sys.executable, "-m", "app.bench.pyrender_child"], input=json.dumps(request),
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    try:
        result = json.loads(proc.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        return {"available": False, "why": f"exit {proc.returncode}: {proc.stderr[-300:]}"}
    if not result.get("ok"):
        return {"available": False, "why": result.get("why", "unknown")}
    ms = sorted(result["ms"])
    median = ms[len(ms) // 2]
    return {"available": True, "ms_median": median, "images_per_s": 1e3 / median}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.bench.batch", description=__doc__)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--size", default="512x512")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cli-runs", type=int, default=3)
    args = parser.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))
    with tempfile.TemporaryDirectory(prefix="pbs-bench-batch-") as tmp:
        folder = Path(tmp)
        jobs = folder / "orbit.toml"
        jobs.write_text(
            f'scene = "{scenes_dir() / "showcase.toml"}"\nsize = "{args.size}"\n'
            f"orbit = {{ frames = {args.frames} }}\n",
            encoding="utf-8",
        )
        result = {
            "scene": "showcase.toml", "frames": args.frames, "size": [w, h],
            "cpus": os.cpu_count(),
            "batch_1": _batch(folder, jobs, 1, args.frames),
            f"batch_{args.workers}": _batch(folder, jobs, args.workers, args.frames),
            "cli_loop": _cli_loop(folder, args.size, args.cli_runs, args.frames),
            "pyrender": _pyrender((w, h), args.frames),
        }  # fmt: skip
    base = result["batch_1"]["images_per_s"]
    result["ratios_to_batch_1"] = {
        name: result[name]["images_per_s"] / base
        for name in (f"batch_{args.workers}", "cli_loop", "pyrender")
        if "images_per_s" in result[name]
    }
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
