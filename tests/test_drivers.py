"""A GL subset of the tests on Mesa's other drivers (docs/drivers.md): softpipe, and zink
over lavapipe (Vulkan). Everything else runs on llvmpipe; a second implementation is where
what only llvmpipe does (its read-back waits, its float rounding, its limits) shows.

Mesa chooses its driver once per process from the environment, so each driver's subset
runs in a child process with that environment: existing tests in a child pytest (context
creation, the G-buffer targets written and read back, the encodings' round trip through
real targets, the lighting and post passes against their float64 twins, the shadow PCF
probe's verdict), the bench's tiny mode, and, on softpipe, the refusal of "sraa", which
needs multisampling it does not have. Each child names the GL_RENDERER it ran on
(tests/gl_renderer_header.py, the bench's bench.json), and the test fails where the
override fell back to another driver.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import moderngl
import numpy as np
import pytest

from app.reference.illumination import shade_gbuffer
from app.reference.tonemap import post_process
from app.render.renderer import Renderer
from app.render.shadows import measure_pcf, probe_hardware_pcf
from app.scene.loader import LoadedScene, load_scene
from tests.gl_renderer_header import HEADER
from tests.test_reference_agreement import MAX_REL_ERR, interior

pytestmark = pytest.mark.gl  # child processes that make GL contexts

REPO = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Driver:
    """A Mesa driver: the environment that selects it, the start of its GL_RENDERER, and
    the headless backends it runs under (OSMesa draws only with a software rasteriser)."""

    name: str
    env: dict[str, str] = field(hash=False)
    renderer: str
    backends: tuple[str, ...]


# LIBGL_ALWAYS_SOFTWARE: EGL's software screen, where GALLIUM_DRIVER picks the driver;
# without it zink's EGL looks for a hardware device and fails, and on a machine with a
# Mesa GPU driver softpipe's would draw on the GPU.
SOFTWARE = {"LIBGL_ALWAYS_SOFTWARE": "1"}
DRIVERS = (
    Driver("softpipe", {**SOFTWARE, "GALLIUM_DRIVER": "softpipe"}, "softpipe", ("egl", "osmesa")),
    Driver("zink", {**SOFTWARE, "GALLIUM_DRIVER": "zink"}, "zink (", ("egl",)),
)
# glvnd's list of EGL vendors cut to Mesa's, so that a GPU vendor's EGL (which knows
# nothing of GALLIUM_DRIVER) cannot take the child's contexts.
MESA_EGL_VENDORS = sorted(Path("/usr/share/glvnd/egl_vendor.d").glob("*mesa*.json"))


def subset(backends: tuple[str, ...]) -> list[str]:
    """The node ids of the subset: every G-buffer layout's targets written and read back,
    each encoding's round trip through a real target (per backend), the lighting and
    post passes against their twins on a small image, and the shadow PCF probe."""
    return [
        "tests/test_gbuffer_layout.py::test_generated_declarations_write_and_sample_each_target",
        "tests/test_gbuffer_layout.py::test_read_fills_every_field",
        *(
            f"tests/test_gbuffer_encoding.py::test_round_trip_through_a_target_glsl_against_twin"
            f"[{backend}-{storage}]"
            for backend in backends
            for storage in ("f32", "unorm16", "f16")
        ),
        "tests/test_drivers.py::test_lighting_and_post_match_their_twins_on_a_small_image",
        "tests/test_drivers.py::test_the_pcf_probe_names_the_drivers_depth_comparison",
    ]


SMALL = (128, 72)
SMALL_SHADOW_MAP = 512  # texels a side: the scenes' 2048 would cost softpipe seconds a map


@pytest.mark.parametrize("scene", ["showcase.toml", "teapot.toml"])
def test_lighting_and_post_match_their_twins_on_a_small_image(gl_egl, scene: str) -> None:
    """tests/test_reference_agreement.py's two comparisons on one small frame with smaller
    shadow maps, cheap enough for the slowest driver: the lighting pass's HDR image against
    app.reference.illumination on the read-back G-buffer (and shadow maps), at its bound;
    the display image against the post pass's twin, within one code value."""
    loaded = load_scene(REPO / "scenes" / scene)
    lights = [
        light.model_copy(update={"shadow_resolution": SMALL_SHADOW_MAP}) if light.shadow else light
        for light in loaded.scene.lights
    ]
    render = loaded.scene.render.model_copy(update={"gbuffer": "f32", "antialiasing": "none"})
    loaded = LoadedScene(
        # the environment left out: the twin sums the punctual lights (the studio's
        # image-based light has its own twin, tests/test_ibl_reference.py)
        loaded.scene.model_copy(update={"lights": lights, "render": render, "environment": None}),
        loaded.path,
    )
    r = Renderer(gl_egl, loaded, SMALL)
    try:
        r.render()
        hdr = r.read_hdr().astype(np.float64)
        ldr = r.read_ldr()
        g = r.read_gbuffer()
        ref = shade_gbuffer(
            g, r.camera, r.lights, loaded.scene.background, r.materials.models,
            r.materials.packed(), shadows=None if r.shadows is None else r.shadows.read(),
        )  # fmt: skip
    finally:
        r.release()
    sel = interior(g.depth > 0.0)
    peak = ref[sel].max()
    lit = sel & (ref.max(axis=-1) > 1e-3 * peak)
    assert lit.sum() > 0.5 * sel.sum() > 0, "too few lit pixels to mean anything"
    rel = np.abs(hdr - ref)[lit] / np.maximum(ref[lit], 1e-3 * peak)
    assert rel.max() <= MAX_REL_ERR, f"max relative error {rel.max():.2e}"
    camera = loaded.scene.camera
    expected = post_process(hdr, camera.exposure, loaded.scene.render.tonemap) * 255.0
    assert np.abs(ldr.astype(np.float64) - expected).max() <= 1.0


# What each driver's LINEAR depth comparison computes (app/render/shadows.py
# probe_models), measured: the weighted 2 x 2 average (the lookup's hardware comparisons
# are exact: SHADOW_COMPARE), or softpipe's comparison of the filtered depth (the lookup
# reads texels instead; docs/shadows.md).
PCF_BEHAVIOUR = {"llvmpipe": "weighted", "softpipe": "filtered depth", "zink": "weighted"}


def test_the_pcf_probe_names_the_drivers_depth_comparison(gl_egl) -> None:
    """The probe that chooses the shadow lookup's path finds this driver's LINEAR depth
    comparison as measured (``PCF_BEHAVIOUR``; on a GL not listed, only that its verdict
    is "exact" for the weighted average alone), and a NEAREST-filtered comparison, which
    any GL makes, not exact."""
    probe = probe_hardware_pcf(gl_egl.ctx)
    name = next((k for k in PCF_BEHAVIOUR if gl_egl.renderer.startswith(k)), None)
    if name is not None:
        assert probe.behaviour == PCF_BEHAVIOUR[name], probe
    assert probe.exact == (probe.behaviour == "weighted"), probe
    nearest = measure_pcf(gl_egl.ctx, moderngl.NEAREST)
    assert nearest.behaviour == "nearest" and not nearest.exact, nearest


# Mesa's driver choices, dropped from this process's environment before a driver's own.
MESA_CHOICES = (
    "GALLIUM_DRIVER", "LIBGL_ALWAYS_SOFTWARE", "MESA_LOADER_DRIVER_OVERRIDE",
    "__EGL_VENDOR_LIBRARY_FILENAMES",
)  # fmt: skip


def _env(driver: Driver) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in MESA_CHOICES}
    env.update(driver.env)
    if MESA_EGL_VENDORS:
        env["__EGL_VENDOR_LIBRARY_FILENAMES"] = str(MESA_EGL_VENDORS[0])
    env["PYTHONPATH"] = str(REPO)
    return env


def _run(args: list[str], driver: Driver, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args], cwd=cwd, env=_env(driver), capture_output=True, text=True,
        timeout=600, check=False,
    )  # fmt: skip


def _ran_on(renderer: str, driver: Driver) -> None:
    assert renderer.startswith(driver.renderer), (
        f"GL_RENDERER is {renderer!r}, not {driver.name}'s: the override fell back"
    )


@pytest.mark.parametrize("driver", DRIVERS, ids=lambda d: d.name)
def test_the_gl_subset_passes_on_the_driver(driver: Driver, tmp_path: Path) -> None:
    ids = subset(driver.backends)
    report = tmp_path / "junit.xml"
    proc = _run(
        ["-m", "pytest", "-p", "no:cacheprovider", "-p", "tests.gl_renderer_header",
         f"--junit-xml={report}", *ids],
        driver, REPO,
    )  # fmt: skip
    out = proc.stdout + proc.stderr
    headers = [line for line in proc.stdout.splitlines() if line.startswith(HEADER)]
    assert headers, out[-4000:]
    _ran_on(headers[0].removeprefix(HEADER), driver)
    assert proc.returncode == 0, out[-4000:]
    suite = ET.parse(report).getroot()
    suite = suite if suite.tag == "testsuite" else suite.find("testsuite")
    counts = {k: int(suite.get(k, 0)) for k in ("tests", "failures", "errors", "skipped")}
    assert counts["failures"] == counts["errors"] == counts["skipped"] == 0, counts
    assert counts["tests"] >= len(ids), counts  # a parametrized id runs each parameter


@pytest.mark.parametrize("driver", DRIVERS, ids=lambda d: d.name)
def test_the_bench_tiny_mode_runs_on_the_driver(driver: Driver, tmp_path: Path) -> None:
    """``pbs bench``'s tiny mode (one suite: the frame at two image sizes, per pass)."""
    proc = _run(
        ["-m", "app.bench", "--quick", "--tiny", "--no-pyrender", "-q",
         "--suites", "resolution", "--out", str(tmp_path)],
        driver, tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-4000:]
    data = json.loads((tmp_path / "bench.json").read_text())
    _ran_on(data["machine"]["gl_renderer"], driver)
    rows = data["rows"]
    assert {(r["suite"], r["width"]) for r in rows} == {("resolution", 160), ("resolution", 320)}
    assert all(np.isfinite(r["ms_median"]) and r["ms_median"] > 0.0 for r in rows), rows
    assert data["machine"]["shadow_pcf"]["behaviour"] == PCF_BEHAVIOUR[driver.name]


SRAA_SCENE = """
[render]
antialiasing = "sraa"
[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
[materials.m]
[[objects]]
shape = "sphere"
material = "m"
[[lights]]
type = "directional"
direction = [0.0, -1.0, -1.0]
"""


def test_sraa_on_softpipe_is_refused_in_one_line(tmp_path: Path) -> None:
    """softpipe draws one sample a pixel (GL_MAX_SAMPLES 1, no sample shading): "sraa"'s
    geometry samples are refused naming the key, exit 2, before anything is written."""
    scene = tmp_path / "s.toml"
    scene.write_text(SRAA_SCENE, encoding="utf-8")
    out = tmp_path / "x.png"
    proc = _run(["-m", "app", "render", str(scene), "--size", "32x18", "-o", str(out)],
                DRIVERS[0], tmp_path)  # fmt: skip
    assert proc.returncode == 2, proc.stderr[-4000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "render.antialiasing" in lines[0] and "s.toml" in lines[0], lines
    assert "at most 1 samples a pixel" in lines[0], lines
    assert not out.exists()


def test_osmesa_refuses_a_driver_it_cannot_draw_with() -> None:
    """Where EGL refuses a GALLIUM_DRIVER (zink without Vulkan, a misspelt name), the `auto`
    backend falls back to OSMesa, which Mesa 22.3 crashes under such a driver (SIGSEGV):
    app/gl/context.py refuses it first, so the process ends on a ContextError naming both
    backends' reasons."""
    driver = Driver("misspelt", {"GALLIUM_DRIVER": "softpipee"}, "", ("egl",))
    code = "from app.gl.context import create_context; create_context('auto')"
    proc = _run(["-c", code], driver, REPO)
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-2000:])
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("app.gl.context.ContextError: no headless OpenGL 3.3 context"), last
    assert "egl: " in last and "osmesa: " in last and "GALLIUM_DRIVER=softpipee" in last, last
