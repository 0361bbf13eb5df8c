"""Suite ``assets``: a real model file rendered by a whole ``pbs render`` process against f3d.

For each asset (``$PBS_BENCH_ASSETS``, paths separated by ``os.pathsep``; else the bundled
scenes/meshes/material_sampler.glb), in alternating rounds, three whole processes at the
same image size:

* ``pbs cold``: ``pbs render MODEL -o out.png --size WxH`` with an empty prepared-texture
  cache (a fresh ``PBS_CACHE_DIR``: every mip chain built, app/textures/cache.py);
* ``pbs cold, unseeded``: the same without the installation's seed either
  (``PBS_CACHE_SEED`` empty: the bundled environment prefiltered too), measured where a
  seed exists (``scripts/dev.sh setup`` writes one; app/render/prepared_seed.py), so
  that the run shows what the seed buys;
* ``pbs warm``: the same with the cache filled by one untimed run before the rounds;
* ``f3d``: app/bench/f3d_child.py (f3d with its antialiasing, HDRI and tone mapping).

Each is measured by a launcher process (this module run as a script, as the startup suite
does, so the child's peak RSS is its own): wall time from spawn to exit, CPU time (user +
system, ``os.wait4``), peak RSS. Mesa's on-disk shader cache is warm for every run (the
machine's state, not the project's), and so is Python's bytecode (a folder of the run's,
``PYTHONPYCACHEPREFIX``, written by an untimed run of each way first, as ``pip install``
compiles an installed package's: a checkout run with ``PYTHONDONTWRITEBYTECODE`` would
otherwise compile pbs's modules from source in every run, a quarter of a second).
``$PBS_BENCH_ASSET_ARGS`` adds arguments to the pbs
command (e.g. an antialiasing setting). The target row compares pbs's warm and cold medians
with f3d's; a contact sheet (pbs's image beside f3d's) goes to the output folder as
``assets-NAME.png``. Without f3d the pbs rows are still measured and the note says why.
"""

from __future__ import annotations

import json
import os
import shlex
import sys
import tempfile
from pathlib import Path

ASSET_SIZE = (480, 480)
TARGET_F3D_RATIO = 0.5  # pbs's whole-process wall time <= this x f3d's
ENV_ASSETS = "PBS_BENCH_ASSETS"
ENV_ARGS = "PBS_BENCH_ASSET_ARGS"
F3D_UNAVAILABLE = 3  # app/bench/f3d_child.py's exit status when f3d cannot run


def bench_assets() -> list[Path]:
    given = os.environ.get(ENV_ASSETS, "")
    if given.strip():
        return [Path(p) for p in given.split(os.pathsep) if p.strip()]
    from app.resources import scenes_dir

    return [scenes_dir() / "meshes" / "material_sampler.glb"]


def seeded() -> bool:
    """Whether this installation's prepared-texture cache has a seed with entries in it
    (app/textures/cache.py ``seed_directories``)."""
    from app.textures.cache_keys import seed_directories

    return any(any(d.glob("*.npy")) for d in seed_directories() if d.is_dir())


def pbs_render_command(model: Path, out: Path, size: tuple[int, int]) -> list[str]:
    from app.bench.startup import pbs_command

    extra = shlex.split(os.environ.get(ENV_ARGS, ""))
    return [*pbs_command(), "render", str(model), "-o", str(out), "--size",
            f"{size[0]}x{size[1]}", "-q", *extra]  # fmt: skip


def f3d_command(model: Path, out: Path, size: tuple[int, int]) -> list[str]:
    return [sys.executable, "-m", "app.bench.f3d_child", str(model), str(out),
            str(size[0]), str(size[1])]  # fmt: skip


def measured(cmd: list[str], env: dict[str, str], timeout: float = 300.0) -> dict:
    """One whole process through the launcher: {"wall_s", "cpu_s", "maxrss_mib",
    "returncode", "stderr"}."""
    from app.bench.startup import launch

    request = {"cmd": cmd, "env": env, "timeout": timeout}
    answer, stderr, returncode = launch("app.bench.assets", request, timeout)
    if answer is None:
        return {"wall_s": None, "cpu_s": None, "maxrss_mib": None,
                "returncode": returncode, "stderr": stderr}  # fmt: skip
    return answer


def _spawn_and_measure(cmd: list[str], env: dict[str, str], timeout: float) -> dict:
    """The launcher's work: spawn ``cmd``, wait with ``os.wait4``, measure."""
    from app.bench.startup import run_to_exit

    run = run_to_exit(cmd, env, timeout)
    return {"wall_s": run.pop("exit_s"), **run}


def run_assets(ctx) -> None:  # ctx: app.bench.context.Context
    """Suite ``assets`` (module docstring)."""
    import statistics

    from app.bench.context import make_row
    from app.bench.startup import pbs_command, repo_pythonpath

    settings = ctx.settings
    size = (64, 64) if settings.mode == "tiny" else ASSET_SIZE
    rounds = max(1, settings.startup_runs)
    base_env = dict(os.environ)
    base_env["PYTHONPATH"] = repo_pythonpath(base_env)
    base_env.pop("PBS_CACHE", None)
    out_dir = getattr(ctx, "out", None)
    for model in bench_assets():
        if not model.is_file():
            ctx.notes.append(f"assets: {model} is not a file; skipped")
            continue
        with tempfile.TemporaryDirectory(prefix="pbs-assets-") as tmp_name:
            tmp = Path(tmp_name)
            # Python's bytecode as an installed package has it (pip compiles it on install):
            # written by the untimed runs below, whatever PYTHONDONTWRITEBYTECODE says here.
            env_all = dict(base_env, PYTHONPYCACHEPREFIX=str(tmp / "bytecode"))
            env_all.pop("PYTHONDONTWRITEBYTECODE", None)
            warm_env = dict(env_all, PBS_CACHE_DIR=str(tmp / "warm-cache"))
            fill = measured(pbs_render_command(model, tmp / "fill.png", size), warm_env)
            if fill["returncode"] != 0:
                ctx.notes.append(f"assets: pbs render {model.name} failed: {fill['stderr']}")
                continue
            measured(f3d_command(model, tmp / "f3d-fill.png", size), env_all)  # as warm
            runs: dict[str, list[dict]] = {"pbs cold": [], "pbs warm": [], "f3d": []}
            if seeded():
                runs["pbs cold, unseeded"] = []
            f3d_why = ""
            for i in range(rounds):
                order = list(runs)
                order = order[i % len(order) :] + order[: i % len(order)]  # rotated
                for way in order:
                    if way == "f3d" and f3d_why:
                        continue
                    ctx.progress.start(f"assets {model.name}: {way}, round {i + 1}/{rounds}")
                    png = tmp / f"{way.replace(' ', '-')}.png"
                    if way == "f3d":
                        result = measured(f3d_command(model, png, size), env_all)
                        if result["returncode"] == F3D_UNAVAILABLE:
                            f3d_why = result["stderr"].strip().splitlines()[-1]
                    else:
                        env = warm_env
                        if way.startswith("pbs cold"):
                            cold = way.replace(",", "").replace(" ", "-")  # a folder per way, round
                            env = dict(env_all, PBS_CACHE_DIR=str(tmp / f"{cold}-{i}"))
                        if way == "pbs cold, unseeded":
                            env["PBS_CACHE_SEED"] = ""
                        result = measured(pbs_render_command(model, png, size), env)
                    ctx.progress.done()
                    if result["returncode"] == 0:
                        runs[way].append(result)
                    elif not (way == "f3d" and f3d_why):
                        code, err = result["returncode"], result["stderr"]
                        ctx.notes.append(f"assets: {way} on {model.name} failed ({code}): {err}")
            if f3d_why:
                ctx.notes.append(f"assets: f3d skipped: {f3d_why}")
            cmd = pbs_render_command(model, Path("out.png"), size)
            command = " ".join(["pbs", *cmd[len(pbs_command()) :]])
            for way, ok in runs.items():
                if not ok:
                    continue
                wall = [r["wall_s"] * 1e3 for r in ok]
                ctx.rows.append(
                    make_row(
                        "assets", model.name, way, size, 0, None,
                        ms_median=statistics.median(wall), ms_min=min(wall), ms_max=max(wall),
                        frames=len(ok), timer="whole process: spawn to exit (os.wait4)",
                        cpu_s_median=statistics.median(r["cpu_s"] for r in ok),
                        peak_rss_mib=max(r["maxrss_mib"] for r in ok),
                        peak_rss_mib_median=statistics.median(r["maxrss_mib"] for r in ok),
                        command=command if way != "f3d" else "f3d (app/bench/f3d_child.py)",
                        runs=ok,
                    )
                )  # fmt: skip
            if out_dir is not None and (tmp / "pbs-warm.png").is_file():
                sheet = Path(out_dir) / f"assets-{model.stem}.png"
                contact_sheet(
                    [(tmp / "pbs-warm.png", "pbs"), (tmp / "f3d.png", "f3d (SSAA, HDRI)")],
                    sheet,
                )


def contact_sheet(images: list[tuple[Path, str]], out: Path) -> None:
    """The images side by side, each labelled underneath (a missing one left out)."""
    from PIL import Image, ImageDraw

    present = [(Image.open(p).convert("RGB"), label) for p, label in images if p.is_file()]
    if not present:
        return
    label_h = 24
    width = sum(im.width for im, _ in present)
    height = max(im.height for im, _ in present) + label_h
    sheet = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    x = 0
    for im, label in present:
        sheet.paste(im, (x, 0))
        draw.text((x + 8, im.height + 6), label, fill=(0, 0, 0))
        x += im.width
    sheet.save(out)


if __name__ == "__main__":
    request = json.loads(sys.argv[1])
    print(json.dumps(_spawn_and_measure(request["cmd"], request["env"], request["timeout"])))
