"""Suite ``peers`` (app/bench/peers.py): pbs against pygfx, PyVista and pyrender, each a
served child (app/bench/peer_child.py); opt-in. At the tiny size: a missing peer is a row
that says why and the rest still runs (cheap: no peer starts); with the peers installed
(the optional ``peers`` extra), every peer's rows, errors and contact sheet (slow). No
test here asserts a time."""

from __future__ import annotations

import importlib.util
import json
import math

import pytest
from PIL import Image

from app.bench import OPT_IN_SUITES, SUITES, _parser, main
from app.bench.context import TINY, Context
from app.bench.peers import CASE, PBS, PEER_NAMES, SIZES, pbs_passes, peers_scene, run_peers
from app.bench.report import peers_verdicts
from app.bench.scenes import load
from app.progress import Progress
from app.render.renderer import Renderer


def test_peers_is_opt_in() -> None:
    assert "peers" in SUITES and "peers" in OPT_IN_SUITES
    assert "peers" not in _parser().parse_args([]).suites.split(",")


def _missing(tmp_path, monkeypatch, name: str) -> None:
    """``name`` not importable in a child, as where it is not installed."""
    shim = tmp_path / "shim" / name
    shim.mkdir(parents=True)
    (shim / "__init__.py").write_text(f"raise ModuleNotFoundError(\"No module named '{name}'\")\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path / "shim"))


@pytest.mark.gl
def test_a_missing_peer_is_a_row_saying_why_and_pbs_still_runs(gl_egl, tmp_path, monkeypatch):
    _missing(tmp_path, monkeypatch, "pygfx")
    ctx = Context(gl_egl, TINY, None, Progress(1, enabled=False), out=tmp_path)
    run_peers(ctx, peers=("pygfx",))
    rows = {r["variant"]: r for r in ctx.rows}
    assert set(rows) == {PBS, "pygfx"}
    assert all(r["suite"] == "peers" and r["case"] == CASE and r["lights"] == 1
               for r in rows.values())  # fmt: skip
    skipped = rows["pygfx"]
    assert skipped["ms_median"] is None and "pygfx is not installed" in skipped["skipped"]
    assert any("pygfx skipped" in n for n in ctx.notes)
    pbs = rows[PBS]
    assert pbs["ms_median"] > 0 and pbs["frames"] >= 2
    assert 0.0 < pbs["flip_mean"] < 0.5 and 0.0 < pbs["rel_rmse"] < 1.0
    [verdict] = peers_verdicts(ctx.rows)
    assert verdict.status == "NOT MEASURED" and "pygfx is not installed" in verdict.measured
    sheet = Image.open(tmp_path / "peers-1.png")  # pbs and the ray-cast
    assert sheet.width == 2 * SIZES["tiny"][0]


def _installed(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


@pytest.mark.slow
@pytest.mark.skipif(not all(_installed(p) for p in PEER_NAMES), reason="the 'peers' extra")
def test_tiny_peers_run_with_every_peer(tmp_path) -> None:
    assert main(["--tiny", "--suites", "peers", "--out", str(tmp_path), "-q"]) == 0
    data = json.loads((tmp_path / "bench.json").read_text())
    rows = {r["variant"]: r for r in data["rows"] if r["suite"] == "peers"}
    assert set(rows) == {PBS, *PEER_NAMES}, [r.get("skipped") for r in rows.values()]
    for name in PEER_NAMES:
        r = rows[name]
        assert r["ms_median"] > 0 and r["over_pbs"]["median"] > 0 and r["antialiasing"]
        # the same scene, seen alike: the ray-cast is near every peer's image
        assert 0.0 < r["flip_mean"] < 0.3 and math.isfinite(r["rel_rmse"]), (name, r)
    [verdict] = [t for t in data["targets"] if t["target"].startswith("pbs >= 3x")]
    assert verdict["status"] in ("PASS", "FAIL")
    assert Image.open(tmp_path / "peers-1.png").width == 3 * SIZES["tiny"][0]


def _row(variant: str, ms: float | None, over: float | None = None, **extra) -> dict:
    ratio = {"median": over, "min": over, "max": over, "rounds": 3} if over else None
    return {"suite": "peers", "case": CASE, "variant": variant, "width": 1280, "height": 720,
            "lights": 32, "ms_median": ms, "over_pbs": ratio, **extra}  # fmt: skip


def test_the_target_takes_the_fastest_peer_that_shades_every_light() -> None:
    """pyrender, faster here because it drops 28 of the 32 lights, is not the peer the
    target compares with; pygfx, slower but shading them all, is."""
    rows = [_row(PBS, 100.0), _row("pygfx", 400.0, 4.0), _row("pyvista", 900.0, 9.0),
            _row("pyrender", 150.0, 1.5, lights_dropped=28)]  # fmt: skip
    [verdict] = peers_verdicts(rows)
    assert verdict.status == "PASS" and verdict.measured.startswith("pygfx/pbs = 4.00x")
    [alone] = peers_verdicts([rows[0], rows[3], _row("pygfx", None, skipped="not installed")])
    assert alone.status == "NOT MEASURED" and "pygfx: not installed" in alone.measured


@pytest.mark.gl
def test_pbs_frame_is_split_into_passes_only_where_they_draw_the_whole_frame(gl_egl) -> None:
    """FXAA's frame splits into its passes (the same image); "sraa" adds a pass the split
    does not know, so its frame is timed whole rather than without it."""
    names = {}
    for aa in ("fxaa", "sraa"):
        data = peers_scene(4, (96, 54))
        data["render"]["antialiasing"] = aa
        r = Renderer(gl_egl, load(data), (96, 54))
        try:
            names[aa] = [p.name for p in pbs_passes(r)]
        finally:
            r.release()
    assert names == {"fxaa": ["gbuffer", "lighting", "fxaa", "read-back"],
                     "sraa": ["render", "read-back"]}  # fmt: skip
