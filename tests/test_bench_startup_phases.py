"""The startup suite's step-by-step cold start (app/bench/startup_phases.py) draws what
``pbs render`` draws, and its children run with Python's bytecode cache (bytecode_env)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from app.bench.startup import BYTECODE_FOLDER, PHASES_BOOT, bytecode_env, repo_pythonpath
from app.resources import scenes_dir

STEPS = (
    "interpreter", "imports: the CLI", "scene read and validated", "imports: GL",
    "EGL context", "Renderer()", "first frame", "read-back", "PNG",
)  # fmt: skip


@pytest.mark.gl
def test_the_steps_write_the_clis_png(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": repo_pythonpath(dict(os.environ))}
    scene = str(scenes_dir() / "showcase.toml")
    ours, cli = tmp_path / "steps.png", tmp_path / "cli.png"
    request = {"t0": time.time(), "scene": scene, "out": str(ours), "size": [48, 27]}
    proc = subprocess.run(
        [sys.executable, "-c", PHASES_BOOT, json.dumps(request)],
        capture_output=True, text=True, env=env, timeout=120, check=True,
    )  # fmt: skip
    answer = json.loads(proc.stdout.splitlines()[-1])
    names = [p[0] for p in answer["phases"]]
    assert len(names) == len(STEPS)
    assert all(n.startswith(s) for n, s in zip(names, STEPS, strict=True))
    assert all(wall >= 0.0 and cpu >= 0.0 for _, wall, cpu in answer["phases"])
    assert answer["programs"] > 0
    subprocess.run(
        [sys.executable, "-m", "app", "render", scene, "-o", str(cli), "--size", "48x27", "-q"],
        env=env, timeout=120, check=True,
    )  # fmt: skip
    assert ours.read_bytes() == cli.read_bytes()


def test_bytecode_env() -> None:
    """Where bytecode may not be written, the children get the bench's own folder for it;
    elsewhere their environment is left as it is."""
    kept = {"PATH": "/bin", "PYTHONPATH": "x"}
    assert bytecode_env(kept) == kept
    got = bytecode_env({**kept, "PYTHONDONTWRITEBYTECODE": "1"})
    assert "PYTHONDONTWRITEBYTECODE" not in got
    assert Path(got["PYTHONPYCACHEPREFIX"]).name == BYTECODE_FOLDER
    mine = bytecode_env({**kept, "PYTHONDONTWRITEBYTECODE": "1", "PYTHONPYCACHEPREFIX": "/c"})
    assert mine["PYTHONPYCACHEPREFIX"] == "/c"
