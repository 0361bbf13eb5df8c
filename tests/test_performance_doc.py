"""docs/performance.md's generated section (scripts/performance_doc.py,
app.bench.report.performance_section): built from a bench.json's rows, written between the
page's two markers and nowhere else. Pure Python: no GL context, no bench run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from app.bench.report import DOC_BEGIN, DOC_END, performance_section, replace_generated

REPO = Path(__file__).resolve().parent.parent


def _row(suite: str, case: str, variant: str, lights: int, ms: float, **extra) -> dict:
    row = {
        "suite": suite, "case": case, "variant": variant, "width": 640, "height": 360,
        "lights": lights, "ms_median": ms, "ms_min": ms * 0.9, "ms_max": ms * 1.1,
        "frames": 5, "passes_ms": {"gbuffer": 1.0, "lighting": ms - 1.0},
        "rel_rmse": None, "max_rel_err": None, "flip_mean": None,
    }  # fmt: skip
    row.update(extra)
    return row


def _payload() -> dict:
    rows = [
        _row("culling", "many lights", "culled", 256, 25.0, lights_per_pixel=16.05,
             lights_per_tile_mean=19.6),
        _row("culling", "many lights", "floor", 256, 20.0),
        _row("culling", "many lights", "unculled", 256, 250.0),
        _row("culling", "many lights", "forward", 256, 300.0),
        _row("accuracy", "fresnel", "schlick", 17, 10.0, rel_rmse=0.05, flip_mean=0.01,
             default=True),
        _row("accuracy", "fresnel", "exact", 17, 12.0, rel_rmse=1e-5, flip_mean=1e-5),
    ]  # fmt: skip
    machine = {
        "mode": "quick", "date": "2026-01-02T03:04:05+00:00", "git": "abc1234",
        "cpu": "Test CPU", "cores_usable": 2, "gl_renderer": "llvmpipe",
        "gl_version": "4.5 (Core Profile) Mesa 22.3.6", "gl_backend": "egl",
        "load_avg_start": [0.5, 0.4, 0.3], "load_avg_end": [1.5, 1.0, 0.5], "wall_s": 12.0,
    }  # fmt: skip
    return {"machine": machine, "rows": rows, "settings": "test settings", "notes": []}


def test_the_section_holds_the_runs_numbers() -> None:
    section = performance_section(_payload())
    assert section.startswith("## Results\n")
    assert "**quick** mode on 2026-01-02 at git abc1234" in section
    assert "indicative" in section  # not the full mode: the verdicts are indicative
    # The culling row: the medians and the ratios computed from them.
    line = next(x for x in section.splitlines() if x.startswith("| 256 |"))
    assert line.split(" | ")[1:6] == ["25.0", "20.0", "-", "250.0", "300.0"]
    assert "| 1.25 | 10.00 | 12.00 | 16.05 (19.6) |" in line
    # Targets: the 256-light verdicts judged from these rows; the Schlick default off
    # its front (exact is slower here, so it is on the front: the row must say PASS).
    assert "| culled at 256 lights <= 1.5x floor | culled/floor = 1.25x" in section
    assert "2 of 2" not in section and "1 of 1 on their fronts | PASS |" in section
    assert "| fresnel | **schlick** | 10.0 |" in section


def test_only_the_text_between_the_markers_changes() -> None:
    doc = f"# Title\n\nhand text\n{DOC_BEGIN}\nold section\n{DOC_END}\n\nmore hand text\n"
    new = replace_generated(doc, "## Results\n\nnew\n")
    assert (
        new
        == f"# Title\n\nhand text\n{DOC_BEGIN}\n## Results\n\nnew\n{DOC_END}\n\nmore hand text\n"
    )
    assert replace_generated(new, "## Results\n\nnew\n") == new  # idempotent
    for broken in (doc.replace(DOC_END, ""), doc.replace(DOC_BEGIN, ""), f"{DOC_END}\n{DOC_BEGIN}"):
        with pytest.raises(ValueError, match="markers"):
            replace_generated(broken, "x\n")


def test_the_script_writes_and_checks_a_page(tmp_path: Path) -> None:
    (tmp_path / "bench.json").write_text(json.dumps(_payload()))
    page = tmp_path / "page.md"
    page.write_text(f"top\n{DOC_BEGIN}\nstale\n{DOC_END}\nbottom\n")
    script = [sys.executable, str(REPO / "scripts" / "performance_doc.py"), str(tmp_path)]
    env_args = {"cwd": REPO, "capture_output": True, "text": True}
    stale = subprocess.run([*script, "--doc", str(page), "--check"], **env_args)
    assert stale.returncode == 1, stale.stdout + stale.stderr
    done = subprocess.run([*script, "--doc", str(page)], **env_args)
    assert done.returncode == 0, done.stderr
    text = page.read_text()
    assert text.startswith(f"top\n{DOC_BEGIN}\n## Results") and text.endswith(
        f"{DOC_END}\nbottom\n"
    )
    again = subprocess.run([*script, "--doc", str(page), "--check"], **env_args)
    assert again.returncode == 0, again.stdout


def test_the_page_has_its_markers_once_and_in_order() -> None:
    """docs/performance.md can be regenerated: both markers, once each, in order."""
    text = (REPO / "docs" / "performance.md").read_text(encoding="utf-8")
    assert text.count(DOC_BEGIN) == 1 and text.count(DOC_END) == 1
    assert text.index(DOC_BEGIN) < text.index(DOC_END)


def test_the_cold_start_steps_are_a_table() -> None:
    """The startup suite's step-by-step row (app/bench/startup_phases.py) is a table of
    its steps with their wall and CPU times, the total and the programs' share."""
    payload = _payload()
    steps = [["interpreter", 0.02, 0.015], ["imports: the CLI", 0.04, 0.035],
             ["PNG encoded and written", 0.09, 0.085]]  # fmt: skip
    payload["rows"].append(
        _row("startup", "showcase.toml", "step by step", 21, 150.0, phases=steps,
             programs_ms=12.0, programs=9)
    )  # fmt: skip
    lines = performance_section(payload).splitlines()
    assert "| imports: the CLI | 40 | 35 |" in lines
    assert "| all | 150 | 135 |" in lines
    assert any("its 9 programs" in line and "12 ms" in line for line in lines)
    assert not any(line.startswith("- showcase.toml, step by step") for line in lines)


def test_each_suite_is_one_section_and_transmission_has_its_table() -> None:
    """The transmission suite's rows make a table of time against exact refraction, and
    the page's generated section holds each suite's table once (the generator once listed
    batch, ibl and shadows twice)."""
    payload = _payload()
    payload["rows"].append(
        _row("transmission", "thin, smooth", "screen-space", 1, 2.9, rel_rmse=1.1e-7,
             max_rel_err=1.2e-6, opaque_ms_median=1.5, unseen=0.0, width=160, height=120)
    )  # fmt: skip
    section = performance_section(payload)
    assert "| thin, smooth | 2.9 | 1.5 | 1.1e-07 | 1.2e-06 | 0.00 |" in section
    page = (REPO / "docs" / "performance.md").read_text(encoding="utf-8")
    generated = page[page.index(DOC_BEGIN) : page.index(DOC_END)]
    headings = [line for line in generated.splitlines() if line.startswith("### ")]
    assert len(headings) == len(set(headings)), headings
