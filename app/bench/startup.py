"""Cold start and peak memory of ``pbs render scenes/showcase.toml -o out.png``.

Each run is a fresh process (the ``pbs`` script beside this interpreter, or
``python -m app``): the time from just before the process is spawned to the PNG's
modification time (written atomically: a temporary file renamed into place), and the
child's peak resident set (``ru_maxrss`` from ``os.wait4``, which reports that child
alone). Mesa keeps compiled shaders in an on-disk cache, so runs after the first reuse
them; runs with ``MESA_SHADER_CACHE_DISABLE=true`` show the start of a machine that has
never compiled them.

The render is spawned by a small launcher process (this module run as a script), not by
the bench itself: ``subprocess`` spawns with vfork, and a child's ``ru_maxrss`` counts the
address space it shared with its parent before ``exec``, so a child of the bench (1.3 GB
of references and light lists by then) measured 1336 MiB for a render that peaks near
265 MiB. The launcher times from just before its own spawn, so its start-up is not counted.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from app.resources import scenes_dir


def pbs_command() -> list[str]:
    """The installed ``pbs`` script next to this interpreter, else ``python -m app``."""
    script = Path(sys.executable).with_name("pbs")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "app"]


def repo_pythonpath(env: dict[str, str]) -> str:
    """PYTHONPATH for a child that must import this checkout's ``app`` (the bench's)."""
    return os.pathsep.join(
        [str(Path(__file__).resolve().parents[2]), env.get("PYTHONPATH", "")]
    ).rstrip(os.pathsep)


def cold_start(
    size: tuple[int, int] | None = None, shader_cache: bool = True, timeout: float = 120.0
) -> dict:
    """One run, through a launcher process (see the module docstring):
    {"to_png_s", "exit_s", "maxrss_mib", "returncode", "command", "stderr"}."""
    env = dict(os.environ)
    env["PYTHONPATH"] = repo_pythonpath(env)
    request = json.dumps({"size": size, "shader_cache": shader_cache, "timeout": timeout})
    proc = subprocess.run(
        [sys.executable, "-m", "app.bench.startup", request],
        capture_output=True, text=True, env=env, timeout=timeout + 60,
    )  # fmt: skip
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if not lines:
        return {
            "to_png_s": None, "exit_s": None, "maxrss_mib": None, "returncode": proc.returncode,
            "command": "pbs render", "stderr": proc.stderr[-500:],
        }  # fmt: skip
    return json.loads(lines[-1])


def spawn_and_measure(
    size: tuple[int, int] | None = None, shader_cache: bool = True, timeout: float = 120.0
) -> dict:
    """The launcher's work: spawn pbs render, wait for it, measure."""
    scene = scenes_dir() / "showcase.toml"
    env = dict(os.environ)
    if not shader_cache:
        env["MESA_SHADER_CACHE_DISABLE"] = "true"
    env["PYTHONPATH"] = repo_pythonpath(env)
    with tempfile.TemporaryDirectory(prefix="pbs-bench-") as tmp:
        out = Path(tmp) / "showcase.png"
        cmd = [*pbs_command(), "render", str(scene), "-o", str(out), "-q"]
        if size is not None:
            cmd += ["--size", f"{size[0]}x{size[1]}"]
        start_ns = time.time_ns()
        t0 = time.perf_counter()
        log = (Path(tmp) / "stderr.txt").open("wb")
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=log)
        deadline = t0 + timeout
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                proc.kill()
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.002)
        exit_s = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        log.close()
        stderr = (Path(tmp) / "stderr.txt").read_text(errors="replace")
        to_png = (out.stat().st_mtime_ns - start_ns) / 1e9 if out.is_file() else None
    return {
        "to_png_s": to_png,
        "exit_s": exit_s,
        "maxrss_mib": usage.ru_maxrss / 1024.0,  # Linux: KiB
        "returncode": proc.returncode,
        "command": " ".join(["pbs", *cmd[len(pbs_command()) :]]),
        "stderr": stderr[-500:],
    }


if __name__ == "__main__":
    args = json.loads(sys.argv[1])
    size = tuple(args["size"]) if args.get("size") else None
    print(json.dumps(spawn_and_measure(size, args["shader_cache"], args["timeout"])))
