"""docs/api.md's examples (docs/examples/*.py) run as a user runs them, as scripts from the
repository root, at small sizes; their outputs are checked so that the docs cannot rot."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.conftest import REPO

pytestmark = pytest.mark.gl  # the examples render

EXAMPLES = REPO / "docs" / "examples"


def run_example(name: str, *args: str) -> str:
    """Run docs/examples/``name`` with ``args``; its stdout (fails on a non-zero exit)."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def png(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


def test_turntable(tmp_path: Path):
    """Four frames a quarter turn apart: all written at the size asked, all different;
    the first is the scene's own camera (a fresh render of the scene file)."""
    out = tmp_path / "tt"
    run_example("turntable.py", "--scene", "sec4_lights", "--frames", "4", "--size", "48x32",
                "--out", str(out))  # fmt: skip
    frames = [png(out / f"frame_{i:03d}.png") for i in range(4)]
    assert all(f.shape == (32, 48, 3) for f in frames)
    assert len({f.tobytes() for f in frames}) == 4
    from app.api import OffscreenRenderer

    with OffscreenRenderer("sec4_lights", (48, 32), backend="egl") as r:
        np.testing.assert_array_equal(frames[0], r.render())


def test_roughness_sweep(tmp_path: Path):
    """Six spheres side by side; the highlight's peak falls as roughness rises (RTR4 §9.6)."""
    out = tmp_path / "sweep.png"
    stdout = run_example("roughness_sweep.py", "--size", "48x48", "--out", str(out))
    assert png(out).shape == (48, 6 * 48, 3)
    peaks = [float(line.rsplit(" ", 1)[1]) for line in stdout.splitlines()]
    assert len(peaks) == 6
    assert all(a > b for a, b in itertools.pairwise(peaks)), peaks


def test_dataset(tmp_path: Path):
    """Three samples: images, depth and normal maps of the size asked, labels that match;
    the same seed gives the same labels and pixels."""
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        run_example("dataset.py", "--samples", "3", "--size", "40x30", "--seed", "7",
                    "--out", str(out))  # fmt: skip
        runs.append(out)
    out = runs[0]
    labels = [json.loads(x) for x in (out / "labels.jsonl").read_text().splitlines()]
    assert [x["image"] for x in labels] == [f"sample_{i:04d}.png" for i in range(3)]
    assert len({json.dumps(x["camera"]) for x in labels}) == 3
    for i in range(3):
        image = png(out / f"sample_{i:04d}.png")
        depth = np.load(out / f"sample_{i:04d}_depth.npy")
        normal = np.load(out / f"sample_{i:04d}_normal.npy")
        assert image.shape == (30, 40, 3)
        assert depth.shape == (30, 40) and depth.dtype == np.float32
        assert normal.shape == (30, 40, 3)
        covered = depth > 0.0
        assert covered.any() and 1.0 < depth[covered].min() < depth[covered].max() < 20.0
        np.testing.assert_allclose(np.linalg.norm(normal[covered], axis=-1), 1.0, atol=1e-5)
        np.testing.assert_array_equal(png(runs[1] / f"sample_{i:04d}.png"), image)
    assert (runs[1] / "labels.jsonl").read_text() == (out / "labels.jsonl").read_text()
