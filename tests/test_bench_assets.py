"""Suite ``assets`` (app/bench/assets.py): whole ``pbs render`` processes on a model file,
cold and warm texture cache, against f3d where it can run; opt-in (not in the default
suites); rows, verdicts and a contact sheet."""

from __future__ import annotations

import json

import pytest
from PIL import Image

from app.bench import OPT_IN_SUITES, SUITES, _parser, main


def test_assets_is_opt_in() -> None:
    assert "assets" in SUITES and "assets" in OPT_IN_SUITES
    default = _parser().parse_args([]).suites.split(",")
    assert "assets" not in default and set(default) == set(SUITES) - set(OPT_IN_SUITES)


@pytest.mark.slow
def test_tiny_assets_run(tmp_path, monkeypatch) -> None:
    monkeypatch.delenv("PBS_BENCH_ASSETS", raising=False)  # the bundled glb
    seed = tmp_path / "seed"  # an installation's seed (one entry no key names): the
    seed.mkdir()  # cold run is also measured without it
    (seed / "unused.npy").write_bytes(b"")
    monkeypatch.setenv("PBS_CACHE_SEED", str(seed))
    assert main(["--quick", "--tiny", "--suites", "assets", "--out", str(tmp_path), "-q"]) == 0
    data = json.loads((tmp_path / "bench.json").read_text())
    rows = {r["variant"]: r for r in data["rows"] if r["suite"] == "assets"}
    assert {"pbs cold", "pbs warm", "pbs cold, unseeded"} <= set(rows)
    for r in rows.values():
        assert r["case"] == "material_sampler.glb" and r["frames"] == 1
        assert r["ms_median"] > 0 and r["cpu_s_median"] > 0 and r["peak_rss_mib"] > 10
    verdicts = [t for t in data["targets"] if t["target"].startswith("material_sampler.glb")]
    if "f3d" in rows:  # the optional peer ran: the verdicts compare with it
        assert [v["status"] for v in verdicts] != ["NOT MEASURED"] * 2
    else:  # it could not: the notes say why
        assert any("f3d skipped" in n for n in data["notes"]), data["notes"]
    sheet = Image.open(tmp_path / "assets-material_sampler.png")
    assert sheet.width == 64 * (2 if "f3d" in rows else 1)
