"""What every suite of the bench shares, below the suites themselves: the modes'
``Settings`` (``FULL``, ``QUICK``, ``TINY``), the ``Context`` a suite runs in, the row
every suite writes (``make_row``) and the cells and rows of its report's tables (``cell``,
``table_lines``), the deferred frame's passes as the bench times them,
the environment of a pyrender child and the helmet-sized mesh scene. The suites' modules
(app/bench/suites.py and the suites of their own: batch, ibl, shadows, spheres) import
from here, so none of them imports another.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from app.bench.scenes import calibrate_range
from app.bench.timing import (
    Budget,
    FrameTimes,
    GLTimerQueries,
    Pass,
    summary,
    time_frames,
    time_interleaved,
)
from app.gl.context import GLContext
from app.progress import Progress
from app.render.renderer import Renderer

PYRENDER_CASE_LIGHTS = 8  # 4 point + 4 spot: the most pyrender shades (4 per type)


@dataclass(frozen=True)
class Settings:
    """Sizes, light counts and frame budgets of one bench mode."""

    mode: str
    culling_size: tuple[int, int]
    light_counts: tuple[int, ...]
    resolutions: tuple[tuple[int, int], ...]
    resolution_lights: int
    accuracy_size: tuple[int, int]
    ms_sizes: tuple[int, ...]
    ms_reference: int
    budget: Budget
    startup_runs: int
    startup_size: tuple[int, int] | None
    pyrender_lights: tuple[int, ...]
    lights_per_pixel: float = 16.0
    specialization_size: tuple[int, int] = (1280, 720)
    specialization_lights: int = 64
    filtering_size: tuple[int, int] = (640, 360)  # scenes/sec13_filtering.toml
    filtering_supersample: int = 8  # the reference's samples per pixel: n x n
    filtering_sweep: int = 5  # camera positions for shimmer
    # The layered models' comparisons (RTR4 §9.10-9.12): the grating's twin sums its orders
    # over 16 wavelengths per pixel and light, minutes at the accuracy size.
    layered_size: tuple[int, int] = (320, 180)
    # Suite batch (app/bench/batch.py): the orbit, each way in rotated rounds.
    batch_frames: int = 100
    batch_size: tuple[int, int] = (512, 512)
    batch_rounds: int = 3
    batch_cli_frames: int = 5  # one pbs render process each
    batch_subdivisions: int = 6  # the mesh: 20 * 4^n triangles
    # Suite shadows (app/bench/shadows.py): the image, and the map sizes (the last one
    # also times no shadow, PCF and PCSS side by side).
    shadow_size: tuple[int, int] = (640, 384)
    shadow_resolutions: tuple[int, ...] = (256, 512, 1024, 2048)
    shadow_showcase_size: tuple[int, int] = (1280, 720)  # the showcase, shadows on and off
    # Suite antialiasing (app/bench/antialiasing.py): the image (8x8 supersampled too).
    antialiasing_size: tuple[int, int] = (640, 360)
    antialiasing_viewer_size: tuple[int, int] = (960, 540)  # showcase, the viewer's window
    # its frames (None: ``budget``): a quick run times it as the full run does, so that its
    # cost verdicts measure the same thing (docs/performance.md, the suite's description)
    antialiasing_budget: Budget | None = None
    # The pyrender comparison (app/bench/spheres.py): its light counts.
    pyrender_sphere_lights: tuple[int, ...] = (1, 4)


FULL = Settings(
    mode="full",
    culling_size=(1280, 720),
    light_counts=(1, 16, 64, 256, 1024),
    resolutions=((640, 360), (1280, 720), (1920, 1080)),
    resolution_lights=64,
    accuracy_size=(1280, 720),
    ms_sizes=(16, 32, 64),
    ms_reference=128,
    budget=Budget(warmup=1, min_frames=3, max_frames=9, seconds=20.0),
    startup_runs=3,
    startup_size=None,
    pyrender_lights=(1, PYRENDER_CASE_LIGHTS),
)
QUICK = replace(
    FULL,
    mode="quick",
    culling_size=(640, 360),
    light_counts=(1, 16, 256),
    resolutions=((640, 360), (1280, 720)),
    accuracy_size=(640, 360),
    ms_sizes=(32, 64),
    ms_reference=128,
    budget=Budget(warmup=1, min_frames=3, max_frames=5, seconds=4.0),
    startup_runs=2,
    pyrender_lights=(1,),
    specialization_size=(640, 360),
    filtering_size=(320, 180),
    layered_size=(160, 90),
    batch_frames=20,
    batch_rounds=2,
    batch_cli_frames=2,
    antialiasing_budget=FULL.budget,
)
# For tests/test_bench.py only: every suite runs, on images small enough to take seconds.
TINY = replace(
    QUICK,
    mode="tiny",
    culling_size=(160, 90),
    light_counts=(1, 16, 64),
    resolutions=((160, 90), (320, 180)),
    resolution_lights=16,
    accuracy_size=(160, 90),
    ms_sizes=(64,),
    ms_reference=64,
    budget=Budget(warmup=1, min_frames=2, max_frames=2, seconds=0.0),
    startup_runs=1,
    startup_size=(160, 90),
    pyrender_lights=(1,),
    specialization_size=(160, 90),
    specialization_lights=16,
    filtering_size=(160, 90),
    layered_size=(64, 36),
    filtering_sweep=2,
    batch_frames=3,
    batch_size=(64, 64),
    batch_rounds=1,
    batch_cli_frames=1,
    batch_subdivisions=2,
    shadow_size=(64, 40),
    shadow_resolutions=(64, 128),
    shadow_showcase_size=(64, 36),
    antialiasing_size=(64, 36),
    antialiasing_viewer_size=(64, 36),
    antialiasing_budget=None,
    pyrender_sphere_lights=(1,),
)


@dataclass
class Context:
    """What every suite needs: the GL context, its timer, the progress bar, the rows."""

    gl: GLContext
    settings: Settings
    queries: GLTimerQueries | None
    progress: Progress
    rows: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    pyrender: bool = True
    pyrender_why: str = ""  # why pyrender is not used, where it is not
    ranges: dict[int, float] = field(default_factory=dict)
    out: Path | None = None  # the output folder (for a suite's images: assets' contact sheet)

    def time(self, passes: list[Pass]) -> FrameTimes:
        return time_frames(self.gl, passes, self.settings.budget, self.queries, self.progress.tick)

    def time_interleaved(
        self, variants: dict[str, list[Pass]], budget: Budget | None = None
    ) -> dict[str, FrameTimes]:
        """Variants to be compared, timed in alternating rounds (timing.time_interleaved),
        within ``budget`` (None: the run's)."""
        budget = self.settings.budget if budget is None else budget
        return time_interleaved(self.gl, variants, budget, self.queries, self.progress.tick)

    def light_range(self, count: int) -> float:
        """The common range giving ~16 lights per surface pixel (cached per count)."""
        if count not in self.ranges:
            self.ranges[count] = calibrate_range(self.gl, count, self.settings.lights_per_pixel)
        return self.ranges[count]


def cell(x: object, spec: str = ".1f") -> str:
    """One cell of a report's table: a float by ``spec``, None (not measured) "-", anything
    else as it prints."""
    if x is None:
        return "-"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def table_lines(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table of a report: ``header``'s row, the separator of as many columns, and
    a row of each list of cells (an empty cell left blank)."""

    def row(cells: list[str]) -> str:
        return "|" + "|".join(f" {c} " if c else " " for c in cells) + "|"

    return [row(header), "|" + "---|" * len(header), *(row(cells) for cells in rows)]


def make_row(
    suite: str,
    case: str,
    variant: str,
    size: tuple[int, int],
    lights: int,
    times: FrameTimes | None,
    **extra: object,
) -> dict:
    """A row with the required keys; timing keys from ``times`` when given."""
    row: dict = {
        "suite": suite,
        "case": case,
        "variant": variant,
        "width": size[0],
        "height": size[1],
        "lights": lights,
        "ms_median": None,
        "ms_min": None,
        "ms_max": None,
        "frames": 0,
        "passes_ms": {},
        "passes_gpu_ms": {},
        "passes_submit_ms": {},
        "timer": None,
        "timer_notes": [],
        "rel_rmse": None,
        "max_rel_err": None,
        "flip_mean": None,
    }
    if times is not None:
        med, lo, hi = summary(times.wall_ms)
        row.update(
            ms_median=med,
            ms_min=lo,
            ms_max=hi,
            frames=len(times.wall_ms),
            passes_ms=times.pass_medians(),
            passes_gpu_ms=times.gpu_medians(),
            passes_submit_ms=times.submit_medians(),
            timer=times.timer,
            timer_notes=times.notes,
        )
    row.update(extra)
    row["load_1min"] = os.getloadavg()[0]
    return row


def deferred_passes(r: Renderer) -> list[Pass]:
    """The deferred frame up to HDR: G-buffer, tile culling (if any), lighting."""
    background = np.asarray(r.scene.background, np.float64)
    passes = [
        Pass(
            "gbuffer",
            lambda: r.gbuffer_pass.run(r.gbuffer, r.view, r.proj, r.camera),
            r.gbuffer.fbo,
        )
    ]
    if r.culler is not None:
        culler = r.culler
        passes.append(
            Pass("cull", lambda: culler.run(r.gbuffer, r.view, r.camera), culler.depth_fbo)
        )
    passes.append(
        Pass("lighting", lambda: r.lighting.run(r.gbuffer, r.camera, background), r.lighting.fbo)
    )
    return passes


def pyrender_env() -> dict[str, str]:
    """The environment of a pyrender child: EGL, and this checkout's ``app`` importable."""
    env = dict(os.environ)
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    env["PYTHONPATH"] = os.pathsep.join(
        [str(Path(__file__).resolve().parents[2]), env.get("PYTHONPATH", "")]
    ).rstrip(os.pathsep)
    return env


def api_mesh_scene(folder: Path, subdivisions: int = 6) -> dict:
    """A helmet-sized mesh (glTF's Damaged Helmet has tens of thousands of triangles):
    an icosphere of ``subdivisions`` (20 * 4^n triangles: 81,920 for 6) written by trimesh
    as ``folder/mesh.glb``, on a floor, under the showcase's kind of light; a scene dict
    whose mesh path is relative to ``folder``."""
    import trimesh

    trimesh.creation.icosphere(subdivisions=subdivisions).export(folder / "mesh.glb")
    return {
        "camera": {"position": [0.0, 1.5, 4.0], "target": [0.0, 0.8, 0.0], "fov_y": 40.0},
        "materials": {
            "metal": {"preset": "gold", "roughness": 0.35},
            "floor": {"base_color": [0.35, 0.35, 0.35], "roughness": 0.8},
        },
        "lights": [
            {"type": "directional", "direction": [-0.4, -1.0, -0.5], "intensity": 2.0},
            {"type": "point", "position": [1.5, 2.5, 1.5], "intensity": 6.0, "range": 10.0},
        ],
        "objects": [
            {"shape": "plane", "size": [20.0, 20.0], "material": "floor"},
            {"shape": "mesh", "file": "mesh.glb", "material": "metal", "position": [0, 0.8, 0]},
        ],
    }
