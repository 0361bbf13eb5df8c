"""The bench's shadows suite (app/bench/shadows.py): its rows exist with tiny settings, and
its mismatch metric is the one of tests/test_shadows.py. No wall-clock assertion: the
times are only checked to be ordered (min <= median <= max)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.bench import main
from app.bench.area_lights import AREA_LIGHTS
from app.bench.area_lights import CASE as AREA_CASE
from app.bench.report import shadow_fronts
from app.bench.shadows import FILTERS, LIGHTS, SHOWCASE, SHOWCASE_VARIANTS, mismatch


@pytest.mark.gl
def test_tiny_shadows_suite_writes_its_rows(tmp_path):
    """Per light type: no shadow, PCF and PCSS at the largest map, PCF and PCSS at each
    smaller one; each shadowed row's mismatch is a fraction, a front exists per light, and
    bench.md has the table."""
    assert main(["--tiny", "--suites", "shadows", "--out", str(tmp_path), "-q"]) == 0
    rows = [r for r in json.loads((tmp_path / "bench.json").read_text())["rows"]]
    assert {r["suite"] for r in rows} == {"shadows"}
    got = {(r["case"], r["variant"]) for r in rows}
    for kind in LIGHTS:
        want = {(kind, "off")} | {(kind, f"{f} {n}") for f in FILTERS[1:] for n in (64, 128)}
        assert want <= got, want - got
    showcase = {r["variant"]: r for r in rows if r["case"] == SHOWCASE}
    assert set(showcase) == set(SHOWCASE_VARIANTS)  # the target's rows, shadows on and off
    assert showcase["shadows"]["shadowed_lights"] == 2
    # the area lights' case (app/bench/area_lights.py): one row per shape, timed
    area = {r["variant"]: r for r in rows if r["case"] == AREA_CASE}
    assert set(area) == set(AREA_LIGHTS) and all(r["ms_median"] > 0 for r in area.values())
    rows = [r for r in rows if r["case"] not in (SHOWCASE, AREA_CASE)]
    for r in rows:
        assert r["ms_min"] <= r["ms_median"] <= r["ms_max"]
        assert r["lit_pixels"] > 100
        if r["variant"] == "off":
            assert r["mismatch"] is None and "shadows" not in r["passes_ms"]
            continue
        assert 0.0 <= r["mismatch"] < 0.5 and "shadows" in r["passes_ms"], r
    fronts = shadow_fronts(rows)
    assert set(fronts) == set(LIGHTS) and all(fronts.values())
    text = (tmp_path / "bench.md").read_text()
    assert "### shadows" in text and "mismatch vs ray-caster" in text
    assert "shadowed showcase frame <=" in text


def test_mismatch_counts_only_lit_pixels_whose_state_differs():
    """A 2 x 2 image: one pixel black unshadowed (left out), one shadowed on the GPU but
    lit in the reference (counted), two agreeing."""
    plain = np.ones((2, 2, 3))
    plain[0, 0] = 0.0
    image = plain.copy()
    image[0, 1] = 0.1  # the GPU says shadowed
    reference = np.array([[False, True], [True, False]])
    image[1, 1] = 0.2  # shadowed in both
    assert mismatch(image, plain, reference) == (1 / 3, 3)
