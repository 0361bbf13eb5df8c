"""Cold start and peak memory of ``pbs render scenes/showcase.toml -o out.png``, and how
soon ``pbs`` answers when it renders nothing (``quick_answers``).

Each run is a fresh process (the ``pbs`` script beside this interpreter, or
``python -m app``): the time from just before the process is spawned to the PNG's
modification time (written atomically: a temporary file renamed into place), and the
child's peak resident set (``ru_maxrss`` from ``os.wait4``, which reports that child
alone). Mesa keeps compiled shaders in an on-disk cache, so runs after the first reuse
them; runs with ``MESA_SHADER_CACHE_DISABLE=true`` show the start of a machine that has
never compiled them.

Python's bytecode cache is warm as Mesa's shader cache is: an installed pbs has its
modules compiled (pip writes the .pyc at install), and a checkout writes them at its first
run, unless the environment says not to (``PYTHONDONTWRITEBYTECODE``, as on the machine
the bench was written on: every run then compiled every module of ``app`` from source,
0.13 s of CPU); there the bench gives its children a bytecode folder of its own
(``bytecode_env``: ``PYTHONPYCACHEPREFIX``), filled by an untimed first run.

``startup_phases`` breaks the cold start down step by step (app/bench/startup_phases.py,
the same steps in a fresh process, each stamped), medians over a few runs.

The render is spawned by a small launcher process (this module run as a script), not by
the bench itself: ``subprocess`` spawns with vfork, and a child's ``ru_maxrss`` counts the
address space it shared with its parent before ``exec``, so a child of the bench (1.3 GB
of references and light lists by then) measured 1336 MiB for a render that peaks near
265 MiB. The launcher times from just before its own spawn, so its start-up is not counted.

``quick_answers`` times the two answers that need no GL: ``pbs --help``, and ``pbs render``
refusing a scene with a misspelt key (the showcase's text with one key changed, so the
whole scene is read and validated before the refusal). Each is a whole process, spawned
by the bench itself (no memory is measured) and timed from just before the spawn to its
exit, the two alternating so that a change of the machine's load falls on both; the CPU
time (user + system, from ``os.wait4``) is kept beside the wall time, as it moves less
with the load of a shared machine.
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

from app.resources import scenes_dir

BYTECODE_FOLDER = "pbs-bench-pycache"  # under the temporary folder (bytecode_env)


def bytecode_env(env: dict[str, str]) -> dict[str, str]:
    """``env`` for a timed child with Python's bytecode cache (module docstring): as it is
    where the environment lets Python write bytecode, else with a bytecode folder of the
    bench's own."""
    if not env.get("PYTHONDONTWRITEBYTECODE"):
        return env
    env = {k: v for k, v in env.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("PYTHONPYCACHEPREFIX", str(Path(tempfile.gettempdir()) / BYTECODE_FOLDER))
    return env


def pbs_command() -> list[str]:
    """The installed ``pbs`` script next to this interpreter, else ``python -m app``."""
    script = Path(sys.executable).with_name("pbs")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "app"]


def repo_pythonpath(env: dict[str, str]) -> str:
    """PYTHONPATH for a child that must import this checkout's ``app`` (the bench's)."""
    return os.pathsep.join(
        [str(Path(__file__).resolve().parents[2]), env.get("PYTHONPATH", "")]
    ).rstrip(os.pathsep)


def launch(module: str, request: dict, timeout: float) -> tuple[dict | None, str, int]:
    """``python -m module REQUEST`` with the repository on PYTHONPATH (a launcher: see the
    module docstring): its last JSON line (None without one), its stderr's tail and its
    exit code."""
    env = dict(os.environ)
    env["PYTHONPATH"] = repo_pythonpath(env)
    proc = subprocess.run(
        [sys.executable, "-m", module, json.dumps(request)],
        capture_output=True, text=True, env=env, timeout=timeout + 60,
    )  # fmt: skip
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    return (json.loads(lines[-1]) if lines else None), proc.stderr[-500:], proc.returncode


def cold_start(
    size: tuple[int, int] | None = None, shader_cache: bool = True, timeout: float = 120.0
) -> dict:
    """One run, through a launcher process (see the module docstring):
    {"to_png_s", "exit_s", "maxrss_mib", "returncode", "command", "stderr"}."""
    request = {"size": size, "shader_cache": shader_cache, "timeout": timeout}
    answer, stderr, returncode = launch("app.bench.startup", request, timeout)
    if answer is None:
        return {
            "to_png_s": None, "exit_s": None, "maxrss_mib": None, "returncode": returncode,
            "command": "pbs render", "stderr": stderr,
        }  # fmt: skip
    return answer


def spawn_and_measure(
    size: tuple[int, int] | None = None, shader_cache: bool = True, timeout: float = 120.0
) -> dict:
    """The launcher's work: spawn pbs render, wait for it, measure."""
    scene = scenes_dir() / "showcase.toml"
    env = dict(os.environ)
    if not shader_cache:
        env["MESA_SHADER_CACHE_DISABLE"] = "true"
    env["PYTHONPATH"] = repo_pythonpath(env)
    env = bytecode_env(env)
    with tempfile.TemporaryDirectory(prefix="pbs-bench-") as tmp:
        out = Path(tmp) / "showcase.png"
        cmd = [*pbs_command(), "render", str(scene), "-o", str(out), "-q"]
        if size is not None:
            cmd += ["--size", f"{size[0]}x{size[1]}"]
        start_ns = time.time_ns()
        run = run_to_exit(cmd, env, timeout)
        to_png = (out.stat().st_mtime_ns - start_ns) / 1e9 if out.is_file() else None
    return {
        "to_png_s": to_png,
        "exit_s": run["exit_s"],
        "maxrss_mib": run["maxrss_mib"],
        "returncode": run["returncode"],
        "command": " ".join(["pbs", *cmd[len(pbs_command()) :]]),
        "stderr": run["stderr"],
    }


# The step-by-step child (app/bench/startup_phases.py): the interpreter's start and the
# CLI's imports stamped here, before anything else of ``app`` is imported.
PHASES_BOOT = """
import time
stamps = [("interpreter", time.time(), time.process_time())]
import app.cli
stamps.append(("imports: the CLI", time.time(), time.process_time()))
from app.bench.startup_phases import main
main(stamps)
"""


def startup_phases(
    size: tuple[int, int] | None = None, runs: int = 3, timeout: float = 120.0
) -> dict:
    """``runs`` cold starts of the showcase step by step (app/bench/startup_phases.py),
    after one untimed run: {"phases": [[name, wall_s median, cpu_s median], ...],
    "programs_s", "programs", "totals_s" (each run's), "runs"}, or {"error": why}."""
    env = bytecode_env({**os.environ, "PYTHONPATH": repo_pythonpath(dict(os.environ))})
    got = []
    with tempfile.TemporaryDirectory(prefix="pbs-bench-phases-") as tmp:
        for i in range(runs + 1):
            request = {"t0": 0.0, "scene": str(scenes_dir() / "showcase.toml"),
                       "out": str(Path(tmp) / "x.png"), "size": size}  # fmt: skip
            cmd = [sys.executable, "-c", PHASES_BOOT]
            request["t0"] = time.time()
            proc = subprocess.run([*cmd, json.dumps(request)], capture_output=True, text=True,
                                  env=env, timeout=timeout)  # fmt: skip
            lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
            if proc.returncode != 0 or not lines:
                return {"error": (proc.stderr.strip().splitlines() or ["?"])[-1]}
            if i > 0:
                got.append(json.loads(lines[-1]))
    names = [p[0] for p in got[0]["phases"]]
    phases = [
        [name, statistics.median(r["phases"][k][1] for r in got),
         statistics.median(r["phases"][k][2] for r in got)]
        for k, name in enumerate(names)
    ]  # fmt: skip
    return {
        "phases": phases,
        "programs_s": statistics.median(r["programs_s"] for r in got),
        "programs": got[0]["programs"],
        "totals_s": [sum(p[1] for p in r["phases"]) for r in got],
        "runs": len(got),
    }


ANSWER_RUNS = 9  # timed runs of each quick answer, after one untimed round
HELP = "help answered"  # the rows' variants
BAD_SCENE = "bad scene refused"
# The showcase's render table with a misspelt key: refused by validation, exit 2.
MISSPELT = ("[render]\n", "[render]\nsupersampel = 2\n")
MISSPELT_KEY = "render.supersampel"  # what the one error line names


def run_to_exit(cmd: list[str], env: dict[str, str], timeout: float) -> dict:
    """One process from spawn to exit, killed past ``timeout``: {"exit_s", "cpu_s",
    "maxrss_mib", "returncode", "stderr"} (CPU time and peak resident set from
    ``os.wait4``, which reports that child alone; the tail of its stderr)."""
    with tempfile.TemporaryFile() as log:
        t0 = time.perf_counter()
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
            time.sleep(0.001)
        exit_s = time.perf_counter() - t0
        log.seek(0)
        stderr = log.read().decode(errors="replace")
    return {
        "exit_s": exit_s,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "maxrss_mib": usage.ru_maxrss / 1024.0,  # Linux: KiB
        "returncode": os.waitstatus_to_exitcode(status),
        "stderr": stderr[-500:],
    }


def quick_answers(runs: int = ANSWER_RUNS, timeout: float = 60.0) -> dict[str, dict]:
    """``pbs --help`` and ``pbs render BAD.toml -o out.png``, ``runs`` times each after
    one untimed round, alternating: per answer {"command", "runs": [run_to_exit's dict
    per run], "ok": whether every run exited as it should (0; 2 with one error line
    naming the key and no PNG), "exit_s_median", "cpu_s_median"}."""
    env = dict(os.environ)
    env["PYTHONPATH"] = repo_pythonpath(env)
    with tempfile.TemporaryDirectory(prefix="pbs-bench-cli-") as tmp:
        scene = Path(tmp) / "bad.toml"
        text = (scenes_dir() / "showcase.toml").read_text(encoding="utf-8")
        assert MISSPELT[0] in text, "the showcase has no [render] table to misspell"
        scene.write_text(text.replace(*MISSPELT, 1), encoding="utf-8")
        out = Path(tmp) / "bad.png"
        commands = {
            HELP: [*pbs_command(), "--help"],
            BAD_SCENE: [*pbs_command(), "render", str(scene), "-o", str(out)],
        }
        results: dict[str, list[dict]] = {name: [] for name in commands}
        for i in range(runs + 1):
            for name, cmd in commands.items():
                run = run_to_exit(cmd, env, timeout)
                if i > 0:
                    results[name].append(run)
        written = out.exists()

    def ok(name: str, run: dict) -> bool:
        if name == HELP:
            return run["returncode"] == 0
        lines = run["stderr"].splitlines()
        return run["returncode"] == 2 and len(lines) == 1 and MISSPELT_KEY in lines[0]

    shown = {HELP: "pbs --help", BAD_SCENE: "pbs render bad.toml -o bad.png"}
    return {
        name: {
            "command": shown[name],
            "runs": got,
            "ok": all(ok(name, r) for r in got) and not (name == BAD_SCENE and written),
            "exit_s_median": statistics.median(r["exit_s"] for r in got),
            "cpu_s_median": statistics.median(r["cpu_s"] for r in got),
        }
        for name, got in results.items()
    }


if __name__ == "__main__":
    args = json.loads(sys.argv[1])
    size = tuple(args["size"]) if args.get("size") else None
    print(json.dumps(spawn_and_measure(size, args["shader_cache"], args["timeout"])))
