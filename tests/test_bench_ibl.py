"""Suite ``ibl`` of ``pbs bench`` at tiny size (app/bench/ibl.py): the rows exist, one per
environment and (face size, samples), with sane prefilter memory, a frame time, and an
error against the brute-force image; the report's table and the front are written.
Never asserts wall-clock times."""

from __future__ import annotations

import json

import pytest

from app.bench import main
from app.bench.ibl import TINY_CHOICES
from app.render.ibl import ENV_LEVELS, face_size, levels_bytes


def test_levels_bytes_counts_six_faces_of_every_level() -> None:
    assert levels_bytes(128) == sum(6 * 16 * face_size(k, 128) ** 2 for k in range(ENV_LEVELS))
    assert levels_bytes(128) == 6 * 16 * (128**2 + 64**2 + 32**2 + 16**2 + 16**2 + 16**2)


@pytest.mark.gl
def test_tiny_ibl_suite_rows(tmp_path) -> None:
    assert main(["--tiny", "--suites", "ibl", "--out", str(tmp_path), "-q"]) == 0
    rows = json.loads((tmp_path / "bench.json").read_text())["rows"]
    assert {r["suite"] for r in rows} == {"ibl"}
    assert sorted({r["case"] for r in rows}) == ["image", "sky", "studio"]
    assert len(rows) == 3 * len(TINY_CHOICES)
    for r in rows:
        assert (r["face_size"], r["samples"]) in TINY_CHOICES
        assert r["prefilter_bytes"] == levels_bytes(r["face_size"])
        assert r["prefilter_ms"] > 0.0 and r["ms_median"] > 0.0 and r["frames"] >= 2
        # the split sum is an approximation: an error, finite and below 100 %
        assert 0.0 < r["rel_rmse"] < 1.0, r
        assert 0.0 < r["flip_mean"] < 1.0, r
    # more samples and a bigger face cost at least as much memory
    by = {(r["case"], r["face_size"]): r["prefilter_bytes"] for r in rows}
    assert by[("sky", 32)] > by[("sky", 16)]
    # each choice is really the one rendered: its prefiltered map, so its error, differs
    for case in ("sky", "studio", "image"):
        errs = {r["rel_rmse"] for r in rows if r["case"] == case}
        assert len(errs) == len(TINY_CHOICES), (case, errs)
    md = (tmp_path / "bench.md").read_text()
    assert "### ibl" in md and "| sky | 16 | 16 |" in md and "front" in md
    assert (tmp_path / "pareto.png").stat().st_size > 1000
