"""Shared fixtures: real headless GL contexts on Mesa (EGL and OSMesa), no mocks."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.gl.context import GLContext, create_context

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session", autouse=True)
def _prepared_cache_dir(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The prepared-texture cache (app/textures/cache.py) in a folder of this session's, so
    that tests neither read a user's entries nor leave their own behind."""
    import os

    os.environ["PBS_CACHE_DIR"] = str(tmp_path_factory.mktemp("pbs-cache"))
    os.environ["PBS_CACHE_SEED"] = ""  # nor an installation's seed (tests count the builds)
    os.environ.pop("PBS_CACHE", None)


@pytest.fixture(scope="module", params=["egl", "osmesa"])
def gl(request: pytest.FixtureRequest) -> GLContext:
    """A headless OpenGL 3.3 context from each backend in turn."""
    context = create_context(request.param)
    yield context
    context.release()


@pytest.fixture(scope="module")
def gl_egl() -> GLContext:
    """The EGL context alone, for tests where the backend does not matter."""
    context = create_context("egl")
    yield context
    context.release()


@pytest.fixture(scope="session")
def xdisplay() -> str:
    """A private X server (Xvfb, installed by scripts/dev.sh) for tests that open real
    windows; DISPLAY points at it for the rest of the session."""
    from app.viewer.xvfb import xvfb

    try:
        with xvfb() as display:
            yield display
    except RuntimeError as exc:
        pytest.fail(str(exc))


# Markers (registered in pyproject.toml; README.md, "Tests"). A test that takes a fixture
# below, directly or through another fixture, gets the marker by that alone; a test that
# makes its GL context another way (a renderer built in the test, a `pbs` child process
# that renders) carries `gl` itself, as a module's `pytestmark` or on the test.
FIXTURE_MARKERS = {"gl": "gl", "gl_egl": "gl", "xdisplay": "viewer"}


# `slow`: tests (node ids under tests/, or their prefix) that took 9 s or more in a run on
# the project's 2-core machine (`pytest -n 2 --durations`, 1-minute loads of 4 to 10).
# Slowness is a measurement, not a property of the code, so it lives here rather than in
# the test files; a test that shares a slow module fixture is listed with the first user.
SLOW = (
    "test_bench.py::test_tiny_run_writes_json_markdown_and_both_plots",
    "test_walkthrough.py::test_every_steps_pairs_and_sweeps_differ_at_their_ends",
    "test_walkthrough.py::test_every_image_is_finite_and_non_negative",
    "test_walkthrough.py::test_comparisons_and_sweeps_differ_between_their_ends",
    "test_walkthrough.py::test_the_bundled_steps_load",
    "test_walkthrough.py::test_no_hangul_font_is_one_line_naming_the_package",
    "test_handout_labels.py::test_no_two_labels_overlap_in_any_view",
    "test_viewer.py::test_500_frames_of_interaction_leak_nothing",
    "test_glsl_strict.py::test_every_assembled_program_passes_glslang",
    "test_viewer.py::test_walkthrough_next_and_previous_through_all_steps",
    "test_viewer.py::test_no_panel_covers_the_image_and_no_label_passes_a_panels_edge",
    "test_stability_renderer.py::test_no_gl_objects_or_memory_leak_over_1000_frames",
    "test_stability_renderer.py::test_stress_scene_hdr_is_finite_and_non_negative",
    "test_screenshots.py::test_scene_matches_its_screenshot[sec11_thin_film]",
    "test_screenshots.py::test_scene_matches_its_screenshot[gltf_core_material]",
    "test_textures_procedural.py::test_write_then_check_then_tamper",
    "test_textures_procedural.py::test_png_bytes_are_deterministic_and_carry_no_metadata",
    "test_stability_brdf.py::test_f16_gbuffer_error_is_bounded[cd grating",
    "test_stability_brdf.py::test_f16_gbuffer_error_is_bounded[fine deep grating",
    "test_batch_faults.py::",
    "test_fiber.py::test_white_furnace[sadeghi",
    "test_diffraction.py::test_bands_against_the_spectral_reference",
    "test_fuzz_scenes.py::test_mutated_",
    "test_attack_gltf.py::test_mutated_gltf_sample",
    "test_attack_bombs.py::test_resource_bombs_are_refused_up_front",
    "test_attack_images.py::",
    "test_cli.py::test_wheel_install_runs_from_anywhere",
    "test_brdf_cli.py::test_one_preset",
    "test_brdf_cli.py::test_two_materials_side_by_side",
    "test_brdf_cli.py::test_scene_file",
    "test_drivers.py::test_the_gl_subset_passes_on_the_driver[softpipe]",
    "test_drivers.py::test_the_bench_tiny_mode_runs_on_the_driver[softpipe]",
)


def _mark_slow(item: pytest.Item) -> None:
    node = item.nodeid.removeprefix("tests/")
    if node.startswith(SLOW):
        item.add_marker("slow")


def _mark_by_fixtures(item: pytest.Item) -> None:
    """``gl`` for the GL context fixtures, ``viewer`` (and so ``gl``) for the X server."""
    used = set(getattr(item, "fixturenames", ()))
    for marker in sorted({FIXTURE_MARKERS[f] for f in used & FIXTURE_MARKERS.keys()}):
        item.add_marker(marker)
    if item.get_closest_marker("viewer") or item.get_closest_marker("browser"):
        item.add_marker("gl")  # a window draws with GL; the handout's images are rendered


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Markers from fixtures (above); and tests marked ``whole`` (an attack suite at full
    size, docs/stability.md) run only when ``-m`` names the marker; every run has their
    sampled versions."""
    for item in items:
        _mark_by_fixtures(item)
        _mark_slow(item)
    if "whole" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="the whole attack suite: run with -m whole")
    for item in items:
        if "whole" in item.keywords:
            item.add_marker(skip)
