"""``pbs bench``: run time against error; docs/performance.md explains it all.

    python -m app.bench [--quick] [--out DIR]
        [--suites culling,resolution,accuracy,specialization,startup,viewer,batch,ibl,
                  shadows,antialiasing,assets,peers]

writes DIR/bench.json ({"machine": {...}, "rows": [...]}), DIR/bench.md (tables, and the
targets with PASS/FAIL and the measured ratios), DIR/pareto.png and
DIR/scaling.png. A progress bar runs on stderr. ``--quick`` uses smaller images and fewer
light counts and frames (a few minutes on two cores); the full run takes tens of minutes,
most of it in the unculled and forward renderers at 1024 lights.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the suites import numpy and GL; app.bench.startup's launcher must not
    from app.bench.context import Settings

__all__ = ["main"]
SUITES = (
    "culling", "resolution", "accuracy", "specialization", "startup", "viewer", "batch", "ibl",
    "shadows", "antialiasing", "assets", "peers", "transmission",
)  # fmt: skip
# Run only when named: third-party renderers (f3d; pygfx, PyVista, pyrender), minutes.
OPT_IN_SUITES = ("assets", "peers")
PYRENDER_SUITES = ("culling", "batch")  # the suites with a pyrender row


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pbs bench",
        description="Measure run time against error: light culling, image size, the accuracy "
        "of each approximation, specialized vs uber lighting shader, cold start, batch "
        "throughput, image-based lighting's prefilter, shadow filters and map sizes, "
        "antialiasing (docs/performance.md, docs/ibl.md, docs/shadows.md, "
        "docs/antialiasing.md).",
    )
    parser.add_argument(
        "--quick", action="store_true", help="smaller images, fewer light counts and frames"
    )
    parser.add_argument(
        "--out", default="bench-results", help="output folder (default: bench-results)"
    )
    parser.add_argument(
        "--suites",
        default=",".join(s for s in SUITES if s not in OPT_IN_SUITES),
        help=f"comma-separated subset of {','.join(SUITES)} (default: all but "
        f"{','.join(OPT_IN_SUITES)})",
    )
    parser.add_argument(
        "--backend", choices=("egl", "osmesa"), default="egl", help="headless GL (default egl)"
    )
    parser.add_argument(
        "--device", type=int, metavar="N",
        help="the EGL device (pbs devices; default $PBS_EGL_DEVICE, else the first)",
    )  # fmt: skip
    parser.add_argument("--no-pyrender", action="store_true", help="skip the pyrender comparison")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    # Test-only: every suite on tiny images (tests/test_bench.py), numbers meaningless.
    parser.add_argument("--tiny", action="store_true", help=argparse.SUPPRESS)
    return parser


def _settings_text(s: Settings, suites: list[str]) -> str:
    parts = []
    if "culling" in suites:
        counts = ", ".join(str(n) for n in s.light_counts)
        parts.append(f"culling {s.culling_size[0]}x{s.culling_size[1]} at {counts} lights")
    if "resolution" in suites:
        sizes = ", ".join(f"{w}x{h}" for w, h in s.resolutions)
        parts.append(f"resolution {sizes} at {s.resolution_lights} lights")
    if "accuracy" in suites:
        parts.append(
            f"accuracy {s.accuracy_size[0]}x{s.accuracy_size[1]} "
            f"(layered models {s.layered_size[0]}x{s.layered_size[1]})"
        )
    if "specialization" in suites:
        w, h = s.specialization_size
        parts.append(f"specialization {w}x{h} at {s.specialization_lights} lights")
    if "batch" in suites:
        w, h = s.batch_size
        parts.append(
            f"batch orbit of {s.batch_frames} frames at {w}x{h}, {s.batch_rounds} rounds,"
            f" CLI loop {s.batch_cli_frames} frames"
        )
    if "ibl" in suites:
        parts.append("ibl: 4 spheres at 96x64, maps 128 wide, 3 environments x 6 prefilter choices")
    if "shadows" in suites:
        w, h = s.shadow_size
        sizes = ", ".join(str(n) for n in s.shadow_resolutions)
        parts.append(f"shadows {w}x{h}, maps of {sizes}")
    if "antialiasing" in suites:
        w, h = s.antialiasing_size
        aa = f"antialiasing {w}x{h} against its 4x4 and 8x8 supersampled frames"
        if s.antialiasing_budget is not None:
            b = s.antialiasing_budget
            aa += f" ({b.min_frames}-{b.max_frames} timed frames a row, as in a full run)"
        parts.append(aa)
    b = s.budget
    parts.append(
        f"{b.warmup} warm-up frame, then {b.min_frames}-{b.max_frames} timed frames"
        f" (more while under {b.seconds:g} s)"
    )
    return "; ".join(parts)


def pyrender_available() -> tuple[bool, str]:
    """Can a child process import pyrender with EGL? (It is the optional ``bench`` extra.)"""
    env = dict(os.environ)
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    try:
        proc = subprocess.run(
            [sys.executable, "-c", "import pyrender"],
            capture_output=True, text=True, env=env, timeout=120,
        )  # fmt: skip
    except (OSError, subprocess.TimeoutExpired) as exc:
        return False, f"pyrender check failed: {exc}"
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return False, f"pyrender is not usable here ({last}); install the 'bench' extra"
    return True, ""


def main(argv: list[str] | None = None) -> int:
    """Run the bench; 0 on success, 1 if a suite failed, 2 on bad arguments."""
    from app.bench import plots, report, suites
    from app.bench.context import FULL, QUICK, TINY
    from app.bench.timing import TIMER_FINISH, TIMER_QUERY, GLTimerQueries
    from app.errors import InputError
    from app.gl.context import create_context
    from app.progress import Progress

    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    chosen = [s.strip() for s in args.suites.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in SUITES]
    if unknown or not chosen:
        print(f"pbs bench: error: unknown suite(s) {', '.join(unknown)}; "
              f"choose from {', '.join(SUITES)}", file=sys.stderr)  # fmt: skip
        return 2
    settings = TINY if args.tiny else QUICK if args.quick else FULL
    out = Path(args.out)
    started = time.perf_counter()
    try:  # before the folder is made: a device out of range writes nothing
        gl = create_context(args.backend, args.device, "--device")
    except InputError as exc:
        print(f"pbs bench: error: {exc}", file=sys.stderr)
        return 2
    if gl.device is not None and args.device is not None:
        # The child processes (pbs batch workers, cold starts, pyrender) on the same device.
        os.environ["PBS_EGL_DEVICE"] = os.environ["EGL_DEVICE_ID"] = str(gl.device)
    out.mkdir(parents=True, exist_ok=True)
    queries = GLTimerQueries.create(gl)
    notes: list[str] = []
    if queries is None:
        notes.append("GL timer queries unavailable: per-pass times from glFinish + perf_counter")
    wants_pyrender = any(s in chosen for s in PYRENDER_SUITES)
    use_pyrender, why = False, ""
    if wants_pyrender and not args.no_pyrender:
        use_pyrender, why = pyrender_available()
        if not use_pyrender:
            notes.append(why)
    elif wants_pyrender:
        why = "pyrender comparison skipped (--no-pyrender)"
        notes.append(why)
    progress = Progress(
        suites.planned_tasks(chosen, settings, use_pyrender), enabled=not args.quiet
    )
    ctx = suites.Context(
        gl,
        settings,
        queries,
        progress,
        notes=notes,
        pyrender=use_pyrender,
        pyrender_why=why,
        out=out,
    )
    timer = f"{TIMER_FINISH}; {TIMER_QUERY}" if queries else f"{TIMER_FINISH} (no timer queries)"
    machine = report.machine_info(gl, timer, settings.mode)
    failed = []
    try:
        for name in chosen:
            try:
                suites.RUNNERS[name](ctx)
            except Exception as exc:  # one suite's failure must not lose the others' rows
                failed.append(name)
                ctx.notes.append(f"suite {name} failed: {type(exc).__name__}: {exc}")
                traceback.print_exc(file=sys.stderr)
    finally:
        if queries is not None:
            queries.release()
        gl.release()
    machine["load_avg_end"] = list(os.getloadavg())
    machine["wall_s"] = round(time.perf_counter() - started, 1)
    text = _settings_text(settings, chosen)
    report.write_json(
        out / "bench.json", machine, ctx.rows,
        {"settings": text, "suites": chosen, "notes": ctx.notes,
         "targets": [v.__dict__ for v in report.evaluate_targets(ctx.rows)]},
    )  # fmt: skip
    report.write_markdown(out / "bench.md", report.markdown(machine, ctx.rows, ctx.notes, text))
    plots.plot_pareto(ctx.rows, out / "pareto.png")
    plots.plot_scaling(ctx.rows, out / "scaling.png")
    if not args.quiet:
        for v in report.evaluate_targets(ctx.rows):
            print(f"{v.status:>12}  {v.target}: {v.measured}")
        print(f"{out / 'bench.md'}: {len(ctx.rows)} rows, {machine['wall_s']:.0f} s")
    return 1 if failed else 0
