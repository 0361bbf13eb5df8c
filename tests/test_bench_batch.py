"""The bench's batch suite (app/bench/batch.py) at a tiny size: its rows, their images and
its ratios. No test here asserts a time: only that each way ran, wrote valid images and
gave finite, positive numbers."""

from __future__ import annotations

import math

import pytest

from app.bench.batch import PYRENDER_MISSING, batch_workers, pyrender_why, run_batch, scene_text
from app.bench.context import TINY, Context, api_mesh_scene
from app.bench.report import BATCH_CLI, BATCH_ONE, BATCH_PYRENDER, batch_ratios, markdown
from app.progress import Progress
from app.scene.loader import load_scene, parse_scene

NO_PYRENDER = "pyrender is not usable here (ModuleNotFoundError: No module named 'pyrender')"


@pytest.fixture
def tiny_rows(gl_egl, tmp_path) -> list[dict]:
    """The suite's rows at TINY (3 frames of 64x64), pyrender left out as if not installed."""
    ctx = Context(gl_egl, TINY, None, Progress(1, enabled=False), pyrender=False,
                  pyrender_why=NO_PYRENDER)  # fmt: skip
    run_batch(ctx, tmp_path)
    return ctx.rows


def test_scene_text_reads_back_as_the_same_scene(tmp_path):
    """The orbit's scene file, written from the dictionary, is the scene the dict is."""
    data = api_mesh_scene(tmp_path, subdivisions=1)
    path = tmp_path / "s.toml"
    path.write_text(scene_text(data), encoding="utf-8")
    assert load_scene(path).scene == parse_scene(data, path).scene


def test_tiny_batch_suite_rows_images_and_ratios(tiny_rows):
    rows = {r["variant"]: r for r in tiny_rows}
    n = batch_workers()
    many = f"pbs batch, {n} workers" if n > 1 else "pbs batch, N workers"
    assert set(rows) == {BATCH_ONE, many, BATCH_CLI, BATCH_PYRENDER}
    assert all(r["suite"] == "batch" and (r["width"], r["height"]) == TINY.batch_size
               for r in tiny_rows)  # fmt: skip
    timed = [r for r in tiny_rows if r["images_per_s"] is not None]
    assert {r["variant"] for r in timed} >= {BATCH_ONE, BATCH_CLI}
    for r in timed:
        # Every image each way wrote decodes whole at the orbit's size.
        assert r["frames"] == r["images_per_round"] * r["rounds"] > 0, r
        assert r["images_valid"] == r["frames"], r
        assert r["ms_min"] <= r["ms_median"] <= r["ms_max"]
        assert r["images_per_s_min"] <= r["images_per_s"] <= r["images_per_s_max"]
        assert math.isfinite(r["steady_ms_median"]) and r["steady_ms_median"] > 0
    assert rows[BATCH_ONE]["images_per_round"] == TINY.batch_frames
    assert rows[BATCH_CLI]["images_per_round"] == TINY.batch_cli_frames
    # Without pyrender its row says so, untimed.
    assert rows[BATCH_PYRENDER]["images_per_s"] is None
    assert rows[BATCH_PYRENDER]["not_measured"].startswith(PYRENDER_MISSING)
    ratios = rows[BATCH_ONE]["ratios"]
    assert ratios == batch_ratios(tiny_rows)
    cli = ratios["CLI loop / pbs batch 1 worker, time per image"]
    assert math.isfinite(cli) and cli > 0
    if n > 1:
        assert math.isfinite(ratios["N workers / 1 worker, images/s"])
    assert ratios["pbs 1 worker / pyrender, images/s (whole run)"] is None
    text = markdown({"mode": "tiny", "date": "-", "git": "-", "cpu": "-", "cores": 2,
                     "cores_usable": 2, "memory_gib": 1, "gl_renderer": "-", "gl_version": "-",
                     "gl_backend": "-", "lp_num_threads": "-", "python": "-", "numpy": "-",
                     "moderngl": "-", "pyrender": "-", "pass_timer": "-",
                     "load_avg_start": [0, 0, 0]}, tiny_rows, [], "tiny")  # fmt: skip
    assert "### batch" in text and f"not measured: {PYRENDER_MISSING}" in text


def test_batch_ratios_are_of_the_right_rows():
    """Each ratio divides the rows it names (made-up rows: 1 worker 4/s, 2 workers 6/s,
    pyrender 2/s; per image 250 ms against a CLI's 2000 ms; warm 200 against 100 ms)."""

    def row(variant: str, ips: float, ms: float, steady: float) -> dict:
        return {"suite": "batch", "variant": variant, "images_per_s": ips, "ms_median": ms,
                "steady_ms_median": steady}  # fmt: skip

    rows = [
        row(BATCH_ONE, 4.0, 250.0, 100.0),
        row("pbs batch, 2 workers", 6.0, 166.0, 190.0),
        row(BATCH_CLI, 0.5, 2000.0, 2000.0),
        row(BATCH_PYRENDER, 2.0, 500.0, 200.0),
    ]
    assert batch_ratios(rows) == {
        "pbs 1 worker / pyrender, images/s (whole run)": 2.0,
        "pbs 1 worker / pyrender, images/s (warm, per image)": 2.0,
        "N workers / 1 worker, images/s": 1.5,
        "CLI loop / pbs batch 1 worker, time per image": 8.0,
    }
    assert pyrender_why(Context(None, TINY, None, None, pyrender_why=NO_PYRENDER)).startswith(  # type: ignore[arg-type]
        PYRENDER_MISSING
    )


def test_a_failed_way_is_a_row_saying_so_and_the_others_still_run(gl_egl, tmp_path, monkeypatch):
    """A way whose process fails (here the CLI loop) leaves an untimed row with the error,
    and the ways after it still run and are timed."""
    import app.bench.batch as batch

    def broken(orbit, tag):
        raise RuntimeError("-m app render: exit 1: boom")

    monkeypatch.setattr(batch, "_cli_loop", broken)
    ctx = Context(gl_egl, TINY, None, Progress(1, enabled=False), pyrender=False,
                  pyrender_why=NO_PYRENDER)  # fmt: skip
    run_batch(ctx, tmp_path)
    rows = {r["variant"]: r for r in ctx.rows}
    assert rows[BATCH_CLI]["images_per_s"] is None
    assert rows[BATCH_CLI]["not_measured"] == "failed: -m app render: exit 1: boom"
    assert rows[BATCH_ONE]["images_valid"] == TINY.batch_frames
    assert any("boom" in note for note in ctx.notes)
