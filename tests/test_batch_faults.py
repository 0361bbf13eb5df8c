"""``pbs batch`` under faults (docs/batch.md, "Faults"), with real processes and signals.

- A worker killed with SIGKILL fails only the job it held; a new worker takes its place
  and every other job renders.
- The parent killed with SIGKILL takes its workers with it, and a caller reading the
  parent's output sees it end (no worker holds it open).
- A second run into a folder another run is writing is refused in one line; the first
  finishes untouched.
- A run removes the temporary files a killed run left, and its manifest is whole JSON
  lines.
- An unreachable ``--scheduler`` is one line and exit 2 within seconds, not a traceback.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from app.batch.run import valid_output

REPO = Path(__file__).resolve().parent.parent
SCENE = """
[render]
width = 160
height = 90
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
[materials.red]
base_color = [0.8, 0.1, 0.1]
roughness = 0.4
[[objects]]
shape = "sphere"
subdivisions = 5
material = "red"
[[lights]]
type = "point"
position = [0.0, 2.0, 2.0]
intensity = 6.0
shadow = true
"""


def _setup(tmp_path: Path, frames: int, size: str = "160x90") -> tuple[Path, Path]:
    (tmp_path / "scene.toml").write_text(SCENE, encoding="utf-8")
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(
        f'scene = "scene.toml"\nsize = "{size}"\norbit = {{ frames = {frames} }}\n',
        encoding="utf-8",
    )
    return jobs, tmp_path / "out"


def _start(jobs: Path, out: Path, *extra: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    argv = [sys.executable, "-m", "app", "batch", str(jobs), "-o", str(out), "-q", *extra]
    return subprocess.Popen(
        argv, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _manifest(out: Path) -> list[dict]:
    text = (out / "manifest.jsonl").read_text(encoding="utf-8")
    assert text.endswith("\n"), "the manifest ends in a partial line"
    return [json.loads(line) for line in text.splitlines()]


def _wait_for(predicate, timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.05)
    pytest.fail(f"timed out waiting for {what}")


def _lines(out: Path) -> int:
    try:
        return len((out / "manifest.jsonl").read_text(encoding="utf-8").splitlines())
    except OSError:
        return 0


@pytest.mark.gl
def test_a_killed_worker_fails_only_its_job(tmp_path: Path) -> None:
    jobs, out = _setup(tmp_path, 48, "320x180")  # long enough that both still work
    proc = _start(jobs, out, "--workers", "2")
    _wait_for(lambda: _lines(out) >= 2, 120, "the first results")
    workers = _children(proc.pid)
    assert len(workers) == 2, workers
    os.kill(workers[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=240)
    lines = _manifest(out)
    assert len(lines) == 48, f"{len(lines)} manifest lines for 48 jobs"
    failed = [line for line in lines if line["status"] == "failed"]
    assert len(failed) <= 1, failed
    for line in failed:
        assert "killed by SIGKILL" in line["error"], line
    assert proc.returncode == (1 if failed else 0), err
    ok = [line for line in lines if line["status"] == "ok"]
    assert len(ok) == 48 - len(failed)
    assert all(valid_output(Path(line["output"]), (320, 180)) for line in ok)


@pytest.mark.gl
def test_the_parent_killed_takes_its_workers(tmp_path: Path) -> None:
    jobs, out = _setup(tmp_path, 120, "320x180")
    proc = _start(jobs, out, "--workers", "2")
    _wait_for(lambda: len(_children(proc.pid)) == 2 and _lines(out) >= 1, 120, "two workers")
    workers = _children(proc.pid)
    os.kill(proc.pid, signal.SIGKILL)
    start = time.monotonic()
    proc.communicate(timeout=20)  # the pipes close: nothing else holds them
    _wait_for(lambda: not any(_alive(w) for w in workers), 10, "the workers to end")
    assert time.monotonic() - start < 20
    # Resume: the folder is free (the kernel dropped the lock) and the rest renders.
    stale = out / ".frame-0119.png.deadbeef.png"
    stale.write_bytes(b"partial")
    again = _start(jobs, out, "--workers", "2")
    _, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert not stale.exists(), "the killed run's temporary file is still there"
    assert not list(out.glob(".frame-*")), list(out.glob(".frame-*"))
    lines = _manifest(out)
    assert len(lines) == 120
    assert {line["status"] for line in lines} <= {"ok", "skipped"}
    assert any(line["status"] == "skipped" for line in lines)


@pytest.mark.gl
def test_a_second_run_into_a_busy_folder_is_refused(tmp_path: Path) -> None:
    jobs, out = _setup(tmp_path, 120, "640x360")
    first = _start(jobs, out)
    _wait_for(lambda: _lines(out) >= 1, 120, "the first run to start")
    second = _start(jobs, out)
    _, err = second.communicate(timeout=60)
    assert first.poll() is None, "the first run ended before the second asked: make it longer"
    assert second.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "another pbs batch" in lines[0] and str(out) in lines[0], err
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    assert len(_manifest(out)) == 120


def test_an_unreachable_scheduler_is_one_line(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    jobs, out = _setup(tmp_path, 2)
    start = time.monotonic()
    proc = _start(jobs, out, "--scheduler", "tcp://127.0.0.1:9")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pbs: error: --scheduler"), err
    assert time.monotonic() - start < 30
