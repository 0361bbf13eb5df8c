"""bench.json and bench.md: the machine, the rows, the targets and the Pareto fronts.

Targets, judged on ``ms_median`` of the rows, never tuned to pass:

* ``culled`` at 256 lights <= 1.5x ``floor``, and >= 8x faster than ``unculled``;
* ``culled`` faster than ``forward`` from 16 lights on (each count on its own);
* cold start to PNG <= 1 s (the median over runs with Mesa's shader cache);
* ``pbs --help`` <= 0.3 s and a bad scene refused <= 0.5 s, whole processes from spawn to
  exit (the medians of alternating runs);
* every default approximation on the Pareto front of its accuracy comparison (nothing
  among the variants both faster and more accurate, by ``ms_median`` and ``rel_rmse``);
* ``specialized`` >= 1.5x faster than ``uber`` on the Lambert-only scene (the mixed-model
  scene's ratio is reported beside it, without a target).
"""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path

from app.bench.context import cell as _fmt
from app.bench.context import table_lines
from app.bench.startup import BAD_SCENE, HELP
from app.gl.context import GLContext
from app.output import atomic_write
from app.render.shadows import hardware_pcf, probe_hardware_pcf
from app.scene.model import DEFAULT_ANTIALIASING

CULLED_FLOOR_MAX = 1.5
UNCULLED_SPEEDUP_MIN = 8.0
COLD_START_MAX_S = 1.0
HELP_MAX_S = 0.3  # pbs --help, spawn to exit
BAD_SCENE_MAX_S = 0.5  # pbs render of a scene with a misspelt key, spawn to exit (code 2)
VIEWER_LATENCY_MAX_MS = 100.0  # an input's wait for its new image in pbs view
VIEWER_IDLE_CPU_MAX = 2.0  # percent of one core an idle pbs view window may take
SPECIALIZED_SPEEDUP_MIN = 1.5
TARGET_LIGHTS = 256
CULLED_LIMIT_MAX = 1.2  # the culled lighting pass against the limit pass
PYRENDER_SPEEDUP_MIN = 5.0  # pyrender / pbs on the 35-sphere scene
SPHERES_CASE = "35 spheres"  # app/bench/spheres.py's CASE (report imports no GL modules)
SPHERES_PYRENDER = "pyrender"
# Suite antialiasing (app/bench/antialiasing.py, docs/antialiasing.md): the still default
# removes >= AA_STILL_REDUCTION_MIN x of the aliased frame's silhouette error (against the
# 4x4 supersampled frame) at <= AA_STILL_COST_MAX x its time; the viewer's interactive
# mode costs <= AA_VIEWER_COST_MAX x; both on the suite's time-vs-error front.
# The still default is the scene model's; the viewer draws the scene's mode while input
# arrives too (its idle frames add jittered samples only where the mode is "jitter").
AA_STILL_DEFAULT: str = DEFAULT_ANTIALIASING
AA_VIEWER_INTERACTIVE = AA_STILL_DEFAULT
AA_STILL_REDUCTION_MIN = 3.0
AA_STILL_COST_MAX = 2.0
AA_VIEWER_COST_MAX = 1.3
SHADOWED_SHOWCASE_MAX = 1.5  # the showcase's frame with its shadows / with none
# Suite peers (app/bench/peers.py): pbs's frame with read-back >= this x faster than the
# fastest peer's (pygfx, PyVista, pyrender), antialiasing on in all, at each light count.
PEERS_SPEEDUP_MIN = 3.0
PEERS_PBS = "pbs"  # app/bench/peers.py's PBS (report imports no GL modules)


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def _version(module: str) -> str:
    try:
        from importlib.metadata import version

        return version(module)
    except Exception:
        return "not installed"


def _git_revision() -> str:
    root = Path(__file__).resolve().parents[2]
    try:
        rev = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root, capture_output=True, text=True,
        ).stdout.strip()  # fmt: skip
        return f"{rev}{' (modified)' if dirty else ''}" if rev else "?"
    except OSError:
        return "?"


def machine_info(gl: GLContext, timer: str, mode: str) -> dict:
    """Where and how the numbers were taken."""
    info = gl.ctx.info
    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    return {
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "mode": mode,
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "cores_usable": affinity,
        "memory_gib": round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1),
        "load_avg_start": list(os.getloadavg()),
        "gl_backend": gl.backend,
        "gl_renderer": str(info.get("GL_RENDERER")),
        "gl_version": str(info.get("GL_VERSION")),
        "gl_vendor": str(info.get("GL_VENDOR")),
        # the shadow lookup's path (hardware comparisons or texel reads) and why
        "shadow_pcf": {**asdict(probe_hardware_pcf(gl.ctx)), "hardware": hardware_pcf(gl.ctx)},
        "lp_num_threads": os.environ.get("LP_NUM_THREADS", "default (one per core)"),
        "pass_timer": timer,
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "numpy": _version("numpy"),
        "moderngl": _version("moderngl"),
        "pyrender": _version("pyrender"),
        "pbs_lab": _version("pbs-lab"),
        "git": _git_revision(),
    }


def write_json(path: Path, machine: dict, rows: list[dict], extra: dict) -> None:
    payload = {"machine": machine, "rows": rows, **extra}
    text = json.dumps(payload, indent=1, default=_jsonable, allow_nan=False)
    atomic_write(path, lambda tmp: tmp.write_text(text + "\n", encoding="utf-8"))


def _jsonable(x: object) -> object:
    if hasattr(x, "tolist"):
        return x.tolist()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    raise TypeError(f"not JSON: {type(x).__name__}")


# --- targets ----------------------------------------------------------------------------------


@dataclass
class Verdict:
    """One target: what it asks, what was measured, PASS / FAIL / NOT MEASURED."""

    target: str
    measured: str
    status: str


def find(rows: list[dict], suite: str, variant: str, lights: int | None = None) -> dict | None:
    """The first timed row of (suite, variant[, lights])."""
    for row in rows:
        if (
            row["suite"] == suite
            and row["variant"] == variant
            and (lights is None or row["lights"] == lights)
            and row.get("ms_median") is not None
        ):
            return row
    return None


def _viewer_idle(rows: list[dict]) -> dict | None:
    """The viewer suite's idle row (CPU, not a time: ``find`` skips it)."""
    return next((r for r in rows if r["suite"] == "viewer" and r["variant"] == "idle"), None)


def _status(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def evaluate_targets(rows: list[dict]) -> list[Verdict]:
    out: list[Verdict] = []
    culled = find(rows, "culling", "culled", TARGET_LIGHTS)
    floor = find(rows, "culling", "floor", TARGET_LIGHTS)
    unculled = find(rows, "culling", "unculled", TARGET_LIGHTS)
    what = f"culled at {TARGET_LIGHTS} lights <= {CULLED_FLOOR_MAX}x floor"
    if culled and floor:
        ratio = culled["ms_median"] / floor["ms_median"]
        lighting = _pass_ratio(culled, floor, ("cull", "lighting"), ("floor",))
        out.append(
            Verdict(what, f"culled/floor = {ratio:.2f}x ({culled['ms_median']:.0f} / "
                    f"{floor['ms_median']:.0f} ms){lighting}", _status(ratio <= CULLED_FLOOR_MAX))
        )  # fmt: skip
    else:
        out.append(Verdict(what, "no 256-light rows", "NOT MEASURED"))
    out.append(_limit_verdict(rows))
    what = f"culled at {TARGET_LIGHTS} lights >= {UNCULLED_SPEEDUP_MIN:g}x faster than unculled"
    if culled and unculled:
        ratio = unculled["ms_median"] / culled["ms_median"]
        out.append(
            Verdict(what, f"unculled/culled = {ratio:.2f}x ({unculled['ms_median']:.0f} / "
                    f"{culled['ms_median']:.0f} ms)", _status(ratio >= UNCULLED_SPEEDUP_MIN))
        )  # fmt: skip
    else:
        out.append(Verdict(what, "no 256-light rows", "NOT MEASURED"))
    counts = sorted(
        {r["lights"] for r in rows if r["suite"] == "culling" and r["variant"] == "forward"}
    )
    for n in (c for c in counts if c >= 16):
        c, f = find(rows, "culling", "culled", n), find(rows, "culling", "forward", n)
        if c and f:
            ratio = f["ms_median"] / c["ms_median"]
            out.append(
                Verdict(f"culled faster than forward at {n} lights",
                        f"forward/culled = {ratio:.2f}x ({f['ms_median']:.0f} / "
                        f"{c['ms_median']:.0f} ms)", _status(ratio > 1.0))
            )  # fmt: skip
    start = find(rows, "startup", "shader cache")
    what = f"cold start to PNG <= {COLD_START_MAX_S:g} s (pbs render scenes/showcase.toml)"
    if start:
        s = start["ms_median"] / 1e3
        uncached = find(rows, "startup", "no shader cache")
        more = (
            f"; without Mesa's shader cache {uncached['ms_median'] / 1e3:.2f} s" if uncached else ""
        )
        measured = (
            f"{s:.2f} s median of {start['frames']} (max {start['ms_max'] / 1e3:.2f} s),"
            f" peak RSS {start['peak_rss_mib']:.0f} MiB{more}"
        )
        out.append(Verdict(what, measured, _status(s <= COLD_START_MAX_S)))
    else:
        out.append(Verdict(what, "not run", "NOT MEASURED"))
    out.extend(_quick_answer_verdicts(rows))
    for interaction in ("orbit", "roughness"):
        row = find(rows, "viewer", interaction)
        if row is None:
            continue  # the viewer suite did not run
        what = (
            f"viewer: an input ({interaction}) waits <= {VIEWER_LATENCY_MAX_MS:g} ms for its"
            f" image (p95, {row['width']}x{row['height']} window)"
        )
        measured = f"p95 {row['ms_p95']:.0f} ms, median {row['ms_median']:.0f} ms"
        out.append(Verdict(what, measured, _status(row["ms_p95"] <= VIEWER_LATENCY_MAX_MS)))
    idle = _viewer_idle(rows)
    if idle is not None:
        what = f"viewer: an idle window takes <= {VIEWER_IDLE_CPU_MAX:g} % of a core"
        measured = f"{idle['cpu_percent']:.2f} % ({idle['frames']} frames drawn while idle)"
        out.append(Verdict(what, measured, _status(idle["cpu_percent"] <= VIEWER_IDLE_CPU_MAX)))
    for comp, front in pareto_by_comparison(rows).items():
        for row in front["rows"]:
            if not row.get("default"):
                continue
            on = row["variant"] in front["front"]
            measured = (
                f"default '{row['variant']}' {'is' if on else 'is not'} on the front"
                f" {_front_text(front)}"
            )
            if not on:
                measured += f"; {front['why'].get(row['variant'], '')}"
            out.append(Verdict(f"default of accuracy '{comp}' on its Pareto front", measured,
                               _status(on)))  # fmt: skip
    out.extend(_pyrender_verdicts(rows))
    out.extend(_assets_verdicts(rows))
    out.append(_specialization_verdict(rows))
    out.extend(_primitives_verdicts(rows))
    out.extend(aa_verdicts(rows))
    out.extend(_shadow_verdicts(rows))
    out.extend(peers_verdicts(rows))
    return out


def _shadow_verdicts(rows: list[dict]) -> list[Verdict]:
    """The shadows suite's target: the showcase's frame with its shadows against the same
    scene with none (app/bench/shadows.py ``run_showcase``); beside it the PCF rows'
    lit/unlit mismatch against the ray-caster at the largest map (nothing where the suite
    did not run)."""
    on = next((r for r in rows if r["suite"] == "shadows" and r["case"] == "showcase"
               and r["variant"] == "shadows"), None)  # fmt: skip
    off = next((r for r in rows if r["suite"] == "shadows" and r["case"] == "showcase"
                and r["variant"] == "no shadows"), None)  # fmt: skip
    if on is None or off is None:
        return []
    ratio = on["ms_median"] / off["ms_median"]
    pcf = [r for r in rows if r["suite"] == "shadows" and str(r["variant"]).startswith("pcf ")]
    largest = max((r["shadow_resolution"] for r in pcf), default=None)
    errors = ", ".join(
        f"{r['case']} {r['mismatch']:.2e}" for r in pcf if r["shadow_resolution"] == largest
    )
    measured = (
        f"{ratio:.2f}x ({on['ms_median']:.0f} / {off['ms_median']:.0f} ms,"
        f" {on['width']}x{on['height']})"
        + (f"; PCF {largest} mismatch vs ray-caster: {errors}" if errors else "")
    )
    what = f"shadowed showcase frame <= {SHADOWED_SHOWCASE_MAX:g}x the same scene without shadows"
    return [Verdict(what, measured, _status(ratio <= SHADOWED_SHOWCASE_MAX))]


def fastest_peer(rows: list[dict], lights: int) -> dict | None:
    """The peers suite's timed peer row with the lowest median at ``lights``, among the
    peers that shade every light (pyrender drops those past 4 per type: a cheaper frame
    of another image)."""
    timed = [
        r for r in rows
        if r["suite"] == "peers" and r["lights"] == lights and r["variant"] != PEERS_PBS
        and r.get("ms_median") is not None and not r.get("lights_dropped")
    ]  # fmt: skip
    return min(timed, key=lambda r: r["ms_median"]) if timed else None


def peers_verdicts(rows: list[dict]) -> list[Verdict]:
    """Suite peers: per light count, pbs against the fastest peer, the ratio of their
    frames per round (timing.round_ratios); NOT MEASURED, with the reasons, where no
    peer ran."""
    out = []
    for pbs in (r for r in rows if r["suite"] == "peers" and r["variant"] == PEERS_PBS):
        n = pbs["lights"]
        what = (
            f"pbs >= {PEERS_SPEEDUP_MIN:g}x faster than the fastest peer, {pbs['case']},"
            f" {n} light(s), {pbs['width']}x{pbs['height']}, frame + 8-bit read-back,"
            " antialiasing on in all"
        )
        peer = fastest_peer(rows, n)
        if peer is None or not peer.get("over_pbs"):
            why = "; ".join(
                f"{r['variant']}: {r['skipped']}" for r in rows
                if r["suite"] == "peers" and r["lights"] == n and r.get("skipped")
            )  # fmt: skip
            out.append(Verdict(what, f"no peer ran ({why or 'none measured'})", "NOT MEASURED"))
            continue
        ratio = peer["over_pbs"]
        measured = (
            f"{peer['variant']}/pbs = {_ratio_text(ratio)} ({peer['ms_median']:.1f} /"
            f" {pbs['ms_median']:.1f} ms)"
        )
        out.append(Verdict(what, measured, _status(ratio["median"] >= PEERS_SPEEDUP_MIN)))
    return out


def peers_lines(members: list[dict]) -> list[str]:
    """The peers suite's table: per light count, pbs and each peer (or why it was
    skipped), time, the ratio to pbs per round, error against the ray-cast."""
    lines = [
        "| lights | renderer | ms median | min | max | renderer / pbs per round |"
        " FLIP (mean) | rel RMSE | antialiasing | version |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in members:
        if r.get("skipped"):
            lines.append(f"| {r['lights']} | {r['variant']} | skipped: {r['skipped']} |"
                         " | | | | | | |")  # fmt: skip
            continue
        ratio = r.get("over_pbs")
        version = r.get("version", "-")
        name = r["variant"]
        if r.get("lights_dropped"):
            name += f" (shades {r['lights'] - r['lights_dropped']} of {r['lights']} lights)"
        lines.append(
            f"| {r['lights']} | {name} | {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])}"
            f" | {_fmt(r['ms_max'])} | {_ratio_text(ratio) if ratio else '-'} |"
            f" {_fmt(r['flip_mean'], '.3f')} | {_fmt(r['rel_rmse'], '.3f')} |"
            f" {r.get('antialiasing', '-')} | {version} |"
        )
    return lines


def _doc_peers(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "peers"]
    if not members:
        return []
    size = f"{members[0]['width']}×{members[0]['height']}"
    return [
        f"### peers ({members[0]['case']}, {size}: frame + 8-bit read-back, interleaved;"
        ' error against the float64 ray-cast; docs/performance.md, "Peers")',
        "",
        *peers_lines(members),
        "",
    ]


ASSETS_F3D_MAX = 0.5  # a model file's whole pbs render <= this x f3d's wall time


def _assets_verdicts(rows: list[dict]) -> list[Verdict]:
    """Suite assets: per asset, pbs's whole-process wall time (texture cache warm, and
    cold) against f3d's; nothing where the suite did not run."""
    out = []
    for case in dict.fromkeys(r["case"] for r in rows if r["suite"] == "assets"):
        f3d = find_case(rows, "assets", case, "f3d")
        for variant in ("pbs warm", "pbs cold"):
            pbs = find_case(rows, "assets", case, variant)
            if pbs is None:
                continue
            what = (
                f"{case}: {variant} render (whole process, {pbs['width']}x{pbs['height']})"
                f" <= {ASSETS_F3D_MAX:g}x f3d's wall time"
            )
            if f3d is None:
                out.append(Verdict(what, "f3d not run", "NOT MEASURED"))
                continue
            ratio = pbs["ms_median"] / f3d["ms_median"]
            measured = (
                f"pbs/f3d = {ratio:.2f}x ({pbs['ms_median'] / 1e3:.2f} / "
                f"{f3d['ms_median'] / 1e3:.2f} s; CPU {pbs['cpu_s_median']:.2f} / "
                f"{f3d['cpu_s_median']:.2f} s)"
            )
            out.append(Verdict(what, measured, _status(ratio <= ASSETS_F3D_MAX)))
    return out


def find_case(rows: list[dict], suite: str, case: str, variant: str) -> dict | None:
    """The row of ``suite`` with this case and variant, or None."""
    for r in rows:
        if r["suite"] == suite and r["case"] == case and r["variant"] == variant:
            return r
    return None


def _assets_lines(members: list[dict]) -> list[str]:
    header = ["asset", "way", "wall s median", "min", "max", "CPU s median", "peak RSS MiB",
              "runs"]  # fmt: skip
    return table_lines(header, [
        [f"{r['case']} ({r['width']}x{r['height']})", r["variant"], f"{r['ms_median'] / 1e3:.2f}",
         f"{r['ms_min'] / 1e3:.2f}", f"{r['ms_max'] / 1e3:.2f}", f"{r['cpu_s_median']:.2f}",
         f"{r['peak_rss_mib']:.0f}", str(r["frames"])]
        for r in members
    ])  # fmt: skip


def _doc_assets(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "assets"]
    if not members:
        return []
    title = "### assets (a model file, whole process, against f3d)"
    return [title, "", *_assets_lines(members), ""]


def aa_front(members: list[dict]) -> list[str]:
    """The antialiasing modes on the front of (time ratio, silhouette error vs the 4x4
    supersampled frame): the timed rows, not those with another setting added
    ("fxaa+specular_aa")."""
    points = {
        r["variant"]: (r["time_ratio"], r["error_silhouette_4"])
        for r in members
        if r.get("time_ratio") is not None
        and r.get("error_silhouette_4") is not None
        and "+" not in r["variant"]
    }
    return pareto_front(points)


def aa_verdicts(rows: list[dict]) -> list[Verdict]:
    """The antialiasing suite's targets (nothing where it did not run)."""
    members = [r for r in rows if r["suite"] == "antialiasing" and r["case"] == "spheres"]
    by = {r["variant"]: r for r in members}
    if not members or "none" not in by:
        return []
    frames = {
        r["variant"]: r for r in rows if r["suite"] == "antialiasing" and r["case"] != "spheres"
    }
    front = aa_front(members)
    none = by["none"]["error_silhouette_4"]
    out = []
    still = by.get(AA_STILL_DEFAULT)
    if still is not None:
        reduction = none / max(still["error_silhouette_4"], 1e-12)
        cost = still["time_ratio"]
        on = AA_STILL_DEFAULT in front
        ok = reduction >= AA_STILL_REDUCTION_MIN and cost <= AA_STILL_COST_MAX and on
        out.append(Verdict(
            f"antialiasing: still default '{AA_STILL_DEFAULT}' removes >="
            f" {AA_STILL_REDUCTION_MIN:g}x of the silhouette error at <= {AA_STILL_COST_MAX:g}x"
            " the frame, on the front",
            f"{reduction:.2f}x less error at {cost:.2f}x the time;"
            f" {'on' if on else 'not on'} the front ({', '.join(front)})",
            _status(ok),
        ))  # fmt: skip
    viewer = frames.get(AA_VIEWER_INTERACTIVE, by.get(AA_VIEWER_INTERACTIVE))
    if viewer is not None:
        cost = viewer["time_ratio"]
        on = AA_VIEWER_INTERACTIVE in front
        out.append(Verdict(
            f"antialiasing: viewer's interactive mode '{AA_VIEWER_INTERACTIVE}' <="
            f" {AA_VIEWER_COST_MAX:g}x the frame, on the front",
            f"{cost:.2f}x on {viewer['case']} {viewer['width']}x{viewer['height']};"
            f" {'on' if on else 'not on'} the front",
            _status(cost <= AA_VIEWER_COST_MAX and on),
        ))  # fmt: skip
    return out


def _aa_lines(members: list[dict]) -> list[str]:
    """The antialiasing suite's table: time ratio to "none", errors against the 4x4 and
    8x8 supersampled frames over every pixel, the silhouettes and the highlight."""
    frames = [r for r in members if r["case"] != "spheres"]
    members = [r for r in members if r["case"] == "spheres"]
    front = aa_front(members)
    first = members[0]
    lines = [
        f"{first['silhouette_pixels']} silhouette pixels, {first['highlight_pixels']} highlight"
        " pixels; errors: mean |display - supersampled display| per channel (0..1).",
        "",
        "| variant | ms median | x none | all, 4x4 | all, 8x8 | silhouette, 4x4 |"
        " silhouette, 8x8 | highlight, 8x8 | on front |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in members:
        ranked = r.get("time_ratio") is not None and "+" not in r["variant"]
        lines.append(
            f"| {r['variant']} | {_fmt(r['ms_median'])} | {_fmt(r.get('time_ratio'), '.2f')} |"
            f" {_fmt(r['error_all_4'], '.2e')} | {_fmt(r['error_all_8'], '.2e')} |"
            f" {_fmt(r['error_silhouette_4'], '.2e')} | {_fmt(r['error_silhouette_8'], '.2e')} |"
            f" {_fmt(r['error_highlight_8'], '.2e')} |"
            f" {('yes' if r['variant'] in front else 'no') if ranked else ''} |"
        )
    if frames:
        lines += [
            "",
            "| frame | variant | ms median | min | max | x none |",
            "|---|---|---|---|---|---|",
        ]
        for r in frames:
            lines.append(
                f"| {r['case']} {r['width']}x{r['height']} | {r['variant']} |"
                f" {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} |"
                f" {_fmt(r['time_ratio'], '.2f')} |"
            )
    return lines


def _quick_answer_verdicts(rows: list[dict]) -> list[Verdict]:
    """``pbs --help`` and a bad scene refused, each within its limit (app/bench/startup.py
    ``quick_answers``): the median wall time of whole processes, and the answer right."""
    out = []
    for variant, limit, label in (
        (HELP, HELP_MAX_S, "`pbs --help`"),
        (BAD_SCENE, BAD_SCENE_MAX_S, "a bad scene refused (the showcase with a misspelt key)"),
    ):
        row = find(rows, "startup", variant)
        what = f"{label} <= {limit:g} s, process spawn to exit"
        if row is None:
            out.append(Verdict(what, "not run", "NOT MEASURED"))
            continue
        s = row["ms_median"] / 1e3
        measured = (
            f"{s:.2f} s median of {row['frames']} alternating runs ({row['ms_min'] / 1e3:.2f}-"
            f"{row['ms_max'] / 1e3:.2f} s), CPU {row['cpu_ms_median'] / 1e3:.2f} s"
        )
        if not row["answered_as_expected"]:
            measured += "; did not answer as expected (see the notes)"
        out.append(Verdict(what, measured, _status(s <= limit and row["answered_as_expected"])))
    return out


# Accuracy targets: the whole pipeline at the default settings against the float64 ray-caster.
PRIMITIVES_MEDIAN_MAX = 1e-5
PRIMITIVES_P99_MAX = 1e-4
PRIMITIVES_FLIP_MAX = 1e-3
PRIMITIVES_BEFORE = "icosphere 4 f16"  # the default before the analytic spheres


def _default_row(rows: list[dict], case: str) -> dict | None:
    """The timed row of the default variant of accuracy comparison ``case``."""
    for row in rows:
        if row["case"] == case and row.get("default") and row.get("ms_median") is not None:
            return row
    return None


def _primitives_verdicts(rows: list[dict]) -> list[Verdict]:
    default = _default_row(rows, "primitives")
    what = (
        f"default settings against the ray-caster: median <= {PRIMITIVES_MEDIAN_MAX:g}, p99 <="
        f" {PRIMITIVES_P99_MAX:g}, mean FLIP <= {PRIMITIVES_FLIP_MAX:g}, exact coverage"
    )
    speed = (
        f"default frame (showcase) no slower than '{PRIMITIVES_BEFORE}' (the default before"
        " the analytic spheres)"
    )
    if default is None:
        return [Verdict(what, "not run", "NOT MEASURED"), Verdict(speed, "not run", "NOT MEASURED")]
    ok = (
        default["rel_median"] <= PRIMITIVES_MEDIAN_MAX
        and default["rel_p99"] <= PRIMITIVES_P99_MAX
        and default["flip_mean"] <= PRIMITIVES_FLIP_MAX
        and default["coverage_mismatch"] == 0.0
    )
    measured = (
        f"'{default['variant']}': median {default['rel_median']:.2e}, p99"
        f" {default['rel_p99']:.2e}, max {default['max_rel_err']:.2e}, FLIP"
        f" {default['flip_mean']:.2e}, coverage mismatch {default['coverage_mismatch']:.2e}"
    )
    out = [Verdict(what, measured, _status(ok))]
    # The speed target is the default scene's frame; the five spheres (mostly background,
    # where the wider f32 G-buffer costs more than the analytic sphere saves) are reported.
    ratios = {}
    for case in ("primitives_showcase", "primitives"):
        now = _default_row(rows, case)
        before = _case_row(rows, "accuracy", case, PRIMITIVES_BEFORE)
        if now is not None and before is not None:
            gb, gb_before = (r.get("passes_ms", {}).get("gbuffer") for r in (now, before))
            passes = f", G-buffer pass {gb / gb_before:.2f}x" if gb and gb_before else ""
            ratios[case] = (
                now["ms_median"] / before["ms_median"],
                f"{now['ms_median'] / before['ms_median']:.2f}x ({now['ms_median']:.1f} /"
                f" {before['ms_median']:.1f} ms{passes})",
            )
    if "primitives_showcase" not in ratios:
        out.append(Verdict(speed, "no showcase rows", "NOT MEASURED"))
    else:
        ratio, text = ratios["primitives_showcase"]
        measured = f"showcase default/before = {text}"
        if "primitives" in ratios:
            measured += f"; five spheres {ratios['primitives'][1]}"
        out.append(Verdict(speed, measured, _status(ratio <= 1.0)))
    return out


BATCH_ONE = "pbs batch, 1 worker"
BATCH_CLI = "CLI loop (pbs render per frame)"
BATCH_PYRENDER = "pyrender in-process"


def _batch_row(rows: list[dict], match: Callable[[str], bool]) -> dict | None:
    for row in rows:
        if row["suite"] == "batch" and match(row["variant"]) and row.get("images_per_s"):
            return row
    return None


def batch_ratios(rows: list[dict]) -> dict[str, float | None]:
    """The batch suite's ratios, from rows of one run (None where a way was not measured):
    pbs with 1 worker against pyrender (images/s of the whole run, and per image once
    warm), N workers against 1, and the CLI loop's time per image against 1 worker's."""
    one = _batch_row(rows, lambda v: v == BATCH_ONE)
    many = _batch_row(rows, lambda v: v.startswith("pbs batch, ") and v != BATCH_ONE)
    cli = _batch_row(rows, lambda v: v == BATCH_CLI)
    pyr = _batch_row(rows, lambda v: v == BATCH_PYRENDER)
    return {
        "pbs 1 worker / pyrender, images/s (whole run)": (
            one["images_per_s"] / pyr["images_per_s"] if one and pyr else None
        ),
        "pbs 1 worker / pyrender, images/s (warm, per image)": (
            pyr["steady_ms_median"] / one["steady_ms_median"] if one and pyr else None
        ),
        "N workers / 1 worker, images/s": (
            many["images_per_s"] / one["images_per_s"] if one and many else None
        ),
        "CLI loop / pbs batch 1 worker, time per image": (
            cli["ms_median"] / one["ms_median"] if one and cli else None
        ),
    }


def _case_row(rows: list[dict], suite: str, case: str, variant: str) -> dict | None:
    for row in rows:
        match = (row["suite"], row["case"], row["variant"]) == (suite, case, variant)
        if match and row.get("ms_median") is not None:
            return row
    return None


def specialization_ratio(rows: list[dict], case: str) -> float | None:
    """uber / specialized frame time of a specialization case (None if either is missing)."""
    spec = _case_row(rows, "specialization", case, "specialized")
    uber = _case_row(rows, "specialization", case, "uber")
    return uber["ms_median"] / spec["ms_median"] if spec and uber else None


def _specialization_verdict(rows: list[dict]) -> Verdict:
    what = f"specialized >= {SPECIALIZED_SPEEDUP_MIN:g}x faster than uber (Lambert-only scene)"
    ratio = specialization_ratio(rows, "lambert")
    if ratio is None:
        return Verdict(what, "specialization suite not run", "NOT MEASURED")
    spec = _case_row(rows, "specialization", "lambert", "specialized")
    uber = _case_row(rows, "specialization", "lambert", "uber")
    measured = (
        f"uber/specialized = {ratio:.2f}x ({uber['ms_median']:.0f} / {spec['ms_median']:.0f} ms)"
    )
    mixed = specialization_ratio(rows, "mixed")
    if mixed is not None:
        measured += f"; mixed-model scene {mixed:.2f}x"
    return Verdict(what, measured, _status(ratio >= SPECIALIZED_SPEEDUP_MIN))


def _ratio_text(r: dict | None) -> str:
    """A per-round ratio (timing.round_ratios): median and range over its rounds."""
    if not r:
        return "-"
    return f"{r['median']:.2f}x ({r['min']:.2f}-{r['max']:.2f} over {r['rounds']} rounds)"


def _limit_verdict(rows: list[dict]) -> Verdict:
    what = (
        f"culled lighting pass (cull + lighting) at {TARGET_LIGHTS} lights <= "
        f"{CULLED_LIMIT_MAX:g}x the limit pass"
    )
    limit = find(rows, "culling", "limit", TARGET_LIGHTS)
    if limit is None or not limit.get("culled_over_limit_lighting"):
        return Verdict(what, f"no {TARGET_LIGHTS}-light limit row", "NOT MEASURED")
    ratio = limit["culled_over_limit_lighting"]
    measured = (
        f"culled/limit, shading passes {_ratio_text(ratio)}; whole frames "
        f"{_ratio_text(limit.get('culled_over_limit'))}"
    )
    return Verdict(what, measured, _status(ratio["median"] <= CULLED_LIMIT_MAX))


def _pass_ratio(a: dict, b: dict, a_passes: tuple[str, ...], b_passes: tuple[str, ...]) -> str:
    pa = sum(a.get("passes_ms", {}).get(p, 0.0) for p in a_passes)
    pb = sum(b.get("passes_ms", {}).get(p, 0.0) for p in b_passes)
    if pa > 0.0 and pb > 0.0:
        return f"; shading passes alone (cull + lighting vs floor) {pa / pb:.2f}x"
    return ""


def _front_text(front: dict) -> str:
    return "(front: " + ", ".join(front["front"]) + ")"


# --- Pareto fronts ----------------------------------------------------------------------------


def pareto_front(points: dict[str, tuple[float, float]]) -> list[str]:
    """Names of the points that no other point dominates: (time, error), both smaller is
    better; q dominates p when q is no worse in both and better in one."""
    front = []
    for name, (t, e) in points.items():
        dominated = any(
            (t2 <= t and e2 <= e) and (t2 < t or e2 < e)
            for other, (t2, e2) in points.items()
            if other != name
        )
        if not dominated:
            front.append(name)
    return front


def pareto_by_comparison(rows: list[dict], suite: str = "accuracy") -> dict[str, dict]:
    """For each comparison (case) of ``suite`` (accuracy, or ibl: one per environment): its
    rows, the front by (ms_median, rel_rmse), and for each variant off the front which
    variant dominates it, and by how much time."""
    out: dict[str, dict] = {}
    comps: dict[str, list[dict]] = {}
    for row in rows:
        timed = row.get("ms_median") is not None and row.get("rel_rmse") is not None
        if row["suite"] == suite and timed:
            comps.setdefault(row["case"], []).append(row)
    for comp, members in comps.items():
        points = {r["variant"]: (r["ms_median"], r["rel_rmse"]) for r in members}
        front = pareto_front(points)
        why = {}
        for r in members:
            if r["variant"] in front:
                continue
            t, e = points[r["variant"]]
            for other in members:
                t2, e2 = points[other["variant"]]
                if other is not r and t2 <= t and e2 <= e:
                    spread = max(r["ms_max"] - r["ms_min"], other["ms_max"] - other["ms_min"])
                    noise = (
                        " (within the min-max spread of the frame times)" if t - t2 < spread else ""
                    )
                    why[r["variant"]] = (
                        f"'{other['variant']}' is {t - t2:.1f} ms faster{noise} and has "
                        f"rel_rmse {e2:.2e} <= {e:.2e}"
                    )
                    break
        out[comp] = {"rows": members, "front": front, "why": why}
    return out


# --- markdown -----------------------------------------------------------------------------------


def _passes(row: dict) -> str:
    """Each pass's wall time, and its timer query in parentheses where it was plausible."""
    wall = row.get("passes_ms") or {}
    query = row.get("passes_gpu_ms") or {}
    parts = []
    for name, ms in wall.items():
        q = f" (q {query[name]:.1f})" if name in query else ""
        parts.append(f"{name} {ms:.1f}{q}")
    return ", ".join(parts) or "-"


def _lights_per_pixel(row: dict) -> str:
    """Measured lights per surface pixel: in range, and (tiled) in its tile's list."""
    text = _fmt(row.get("lights_per_pixel"), ".2f")
    tile = row.get("lights_per_tile_mean")
    return f"{text} (tile {tile:.1f})" if tile is not None else text


def timer_summary(rows: list[dict]) -> str | None:
    """Which passes' timer queries were discarded, in how many rows."""
    counts: dict[str, int] = {}
    for row in rows:
        for name in row.get("passes_ms") or {}:
            if name not in (row.get("passes_gpu_ms") or {}):
                counts[name] = counts.get(name, 0) + 1
    if not counts:
        return None
    listed = ", ".join(f"{name} ({n} rows)" for name, n in sorted(counts.items()))
    return (
        "GL_TIME_ELAPSED results outside [0.5, 1] x the pass's wall time were discarded for: "
        f"{listed}; those passes show only their wall time."
    )


def markdown(machine: dict, rows: list[dict], notes: list[str], settings_text: str) -> str:
    """bench.md: the machine, the targets, then a table per suite."""
    lines = [
        "# pbs bench",
        "",
        f"Mode **{machine['mode']}** ({settings_text}); {machine['date']}; git {machine['git']}.",
        "",
        "## Machine",
        "",
        f"- CPU: {machine['cpu']}, {machine['cores']} cores ({machine['cores_usable']} usable),"
        f" {machine['memory_gib']} GiB",
        f"- GL: {machine['gl_renderer']} / {machine['gl_version']} ({machine['gl_backend']}),"
        f" llvmpipe threads: {machine['lp_num_threads']}",
        f"- Python {machine['python']}, numpy {machine['numpy']}, moderngl {machine['moderngl']},"
        f" pyrender {machine['pyrender']}",
        f"- Per-pass timer: {machine['pass_timer']}; frame time: wall clock, glFinish to glFinish",
        f"- Load average (1, 5, 15 min) at start: "
        f"{', '.join(f'{x:.2f}' for x in machine['load_avg_start'])}; at end: "
        f"{', '.join(f'{x:.2f}' for x in machine.get('load_avg_end', []))}",
        "",
        "## Targets",
        "",
    ]
    if machine["mode"] != "full":
        lines += [
            "The targets are stated for the full mode (the culling suite at 1280x720, "
            "frames of 20 s per row); in this mode the verdicts are indicative only: a "
            "smaller image weighs each pass's fixed cost more, and fewer frames leave more "
            "noise.",
            "",
        ]
    lines += ["| target | measured | result |", "|---|---|---|"]
    for v in evaluate_targets(rows):
        lines.append(f"| {v.target} | {v.measured} | **{v.status}** |")
    lines += ["", "## Results", ""]
    suites = (
        "culling", "resolution", "accuracy", "specialization", "startup", "viewer", "batch", "ibl",
        "shadows", "assets",
        "shadows", "antialiasing", "peers", "transmission",
    )  # fmt: skip
    for suite in suites:
        members = [r for r in rows if r["suite"] == suite]
        if not members:
            continue
        lines += [f"### {suite}", ""]
        if suite == "culling":
            lines += [
                "| lights | variant | ms median | min | max | passes, ms (q: timer query) |"
                " lights per pixel: in range (in tile list) | rel_rmse | max_rel_err | FLIP |",
                "|---|---|---|---|---|---|---|---|---|---|",
            ]
            for r in members:
                if r["case"] == SPHERES_CASE:
                    continue  # their own table, below
                lines.append(
                    f"| {r['lights']} | {r['variant']} | {_fmt(r['ms_median'])} |"
                    f" {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} | {_passes(r)} |"
                    f" {_lights_per_pixel(r)} | {_fmt(r['rel_rmse'], '.2e')} |"
                    f" {_fmt(r['max_rel_err'], '.2e')} | {_fmt(r['flip_mean'], '.2e')} |"
                )
            lines += _culling_ratio_lines(members)
        elif suite == "resolution":
            lines += [
                "| size | lights | ms median | min | max | passes, ms (q: timer query) |"
                " ns per pixel |",
                "|---|---|---|---|---|---|---|",
            ]
            for r in members:
                per_px = r["ms_median"] * 1e6 / (r["width"] * r["height"])
                lines.append(
                    f"| {r['case']} | {r['lights']} | {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])}"
                    f" | {_fmt(r['ms_max'])} | {_passes(r)} | {per_px:.0f} |"
                )
        elif suite == "accuracy":
            fronts = pareto_by_comparison(rows)
            lines += [
                "| comparison | variant | default | ms median | min | max | lighting ms |"
                " rel_rmse | max_rel_err | FLIP | on front |",
                "|---|---|---|---|---|---|---|---|---|---|---|",
            ]
            for r in members:
                front = fronts.get(r["case"], {}).get("front", [])
                lighting = (r.get("passes_ms") or {}).get("lighting")
                lines.append(
                    f"| {r['case']} | {r['variant']} | {'yes' if r.get('default') else ''} |"
                    f" {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} |"
                    f" {_fmt(lighting)} | {_fmt(r['rel_rmse'], '.2e')} |"
                    f" {_fmt(r['max_rel_err'], '.2e')} | {_fmt(r['flip_mean'], '.2e')} |"
                    f" {'yes' if r['variant'] in front else 'no'} |"
                )
            lines.append("")
            for comp, front in fronts.items():
                title = front["rows"][0].get("comparison", comp)
                lines.append(f"- **{comp}** ({title}): front {', '.join(front['front'])}.")
                for variant, why in front["why"].items():
                    lines.append(f"  - '{variant}' is dominated: {why}.")
            shimmering = [r for r in members if r.get("shimmer") is not None]
            if shimmering:
                lines += [
                    "",
                    "Shimmer (mean over pixels of the standard deviation of displayed luminance"
                    " over a sideways camera sweep; app/bench/filtering.py):",
                    "",
                    "| comparison | variant | shimmer | rel_rmse | FLIP |",
                    "|---|---|---|---|---|",
                ]
                lines += [
                    f"| {r['case']} | {r['variant']} | {r['shimmer']:.5f} |"
                    f" {_fmt(r['rel_rmse'], '.2e')} | {_fmt(r['flip_mean'], '.2e')} |"
                    for r in shimmering
                ]
        elif suite == "specialization":
            lines += [
                "| scene | variant | model groups | lighting programs | ms median | min | max |"
                " lighting ms | uber / specialized | max rel. diff. from specialized |"
                " rel_rmse | FLIP |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|",
            ]
            for r in members:
                lighting = (r.get("passes_ms") or {}).get("lighting")
                ratio = specialization_ratio(rows, r["case"]) if r["variant"] == "uber" else None
                lines.append(
                    f"| {r['case']} | {r['variant']} | {r.get('model_groups', '-')} |"
                    f" {r.get('lighting_programs', '-')} | {_fmt(r['ms_median'])} |"
                    f" {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} | {_fmt(lighting)} |"
                    f" {_fmt(ratio, '.2f')} | {_fmt(r.get('max_rel_diff_vs_specialized'), '.1e')}"
                    f" | {_fmt(r['rel_rmse'], '.2e')} | {_fmt(r['flip_mean'], '.2e')} |"
                )
        elif suite == "viewer":
            lines += [
                "| interaction | window | ms median | p95 | min | max | frames | CPU % of a core |",
                "|---|---|---|---|---|---|---|---|",
            ]
            for r in members:
                lines.append(
                    f"| {r['variant']} | {r['width']}x{r['height']} | {_fmt(r['ms_median'])} |"
                    f" {_fmt(r.get('ms_p95'))} | {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} |"
                    f" {r['frames']} | {_fmt(r.get('cpu_percent'), '.2f')} |"
                )
        elif suite == "batch":
            lines += _batch_lines(members)
        elif suite == "ibl":
            lines += _ibl_lines(rows, members)
        elif suite == "shadows":
            lines += _shadow_lines(members)
        elif suite == "assets":
            lines += _assets_lines(members)
        elif suite == "antialiasing":
            lines += _aa_lines(members)
        elif suite == "peers":
            lines += peers_lines(members)
        elif suite == "transmission":
            from app.bench.transmission import transmission_lines

            lines += transmission_lines(members)
        else:
            lines += [
                "| case | variant | ms median (to PNG, or to exit) | min | max | peak RSS MiB |"
                " runs |",
                "|---|---|---|---|---|---|---|",
            ]
            for r in members:
                size = f" ({r['width']}x{r['height']})" if r["width"] else ""
                lines.append(
                    f"| {r['case']}{size} | {r['variant']} |"
                    f" {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} |"
                    f" {_fmt(r.get('peak_rss_mib'), '.0f')} | {r['frames']} |"
                )
        lines.append("")
    lines += [
        "## Not measured",
        "",
        "- Normal encodings: the G-buffer offers one (octahedral normals), so there are no"
        " variants.",
        "",
    ]
    summary = timer_summary(rows)
    notes = [*notes, summary] if summary else notes
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)


def shadow_fronts(rows: list[dict]) -> dict[str, list[str]]:
    """Per light type of the shadows suite: the variants on the front of (frame ms,
    lit/unlit mismatch fraction), among the shadowed rows."""
    out: dict[str, list[str]] = {}
    for case in dict.fromkeys(r["case"] for r in rows if r["suite"] == "shadows"):
        points = {
            r["variant"]: (r["ms_median"], r["mismatch"])
            for r in rows
            if r["suite"] == "shadows" and r["case"] == case and r.get("mismatch") is not None
        }
        if points:  # the showcase's rows (on and off) have no mismatch
            out[case] = pareto_front(points)
    return out


def _shadow_lines(members: list[dict]) -> list[str]:
    """The shadows suite's table: frame time (shadow pass redrawn each frame), its passes,
    the lit/unlit mismatch against the ray-caster, and the time-vs-error front."""
    fronts = shadow_fronts(members)
    lines = [
        "| light | variant | ms median | min | max | shadow pass ms | lighting ms |"
        " mismatch vs ray-caster | on front |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in members:
        passes = r.get("passes_ms") or {}
        on = (
            ""
            if r.get("mismatch") is None
            else "yes"
            if r["variant"] in fronts[r["case"]]
            else "no"
        )
        lines.append(
            f"| {r['case']} | {r['variant']} | {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])} |"
            f" {_fmt(r['ms_max'])} | {_fmt(passes.get('shadows'))} |"
            f" {_fmt(passes.get('lighting'))} | {_fmt(r.get('mismatch'), '.2e')} | {on} |"
        )
    return lines


def _culling_ratio_lines(members: list[dict]) -> list[str]:
    """culled/limit per light count (per-round ratios of one interleaved run), and the
    pyrender comparisons' ratios."""
    limits = [r for r in members if r["variant"] == "limit" and r.get("culled_over_limit")]
    lines = []
    if limits:
        lines += [
            "",
            "culled/limit (the limit pass: the pixel's own lights, a fixed-count loop, light"
            " parameters in uniforms; app/bench/limit.py), per round of the interleaved run:",
            "",
            "| lights | limit: lights per pixel (form) | whole frames | cull + lighting vs"
            " limit pass |",
            "|---|---|---|---|",
        ]
        lines += [
            f"| {r['lights']} | {r['limit_lights_per_pixel']} ({r['limit_form']}) |"
            f" {_ratio_text(r['culled_over_limit'])} |"
            f" {_ratio_text(r.get('culled_over_limit_lighting'))} |"
            for r in limits
        ]
    frames = [r for r in members if r["variant"] == "frame"]
    if frames:
        lines += [
            "",
            "Fixed cost: the whole frame to the caller's 8-bit image (G-buffer, cull where the"
            ' default light_culling = "auto" tiles, lighting, post, read-back), timed'
            " interleaved with the variants above:",
            "",
            "| lights | size | ms median | min | max | passes, ms |",
            "|---|---|---|---|---|---|",
        ]
        lines += [
            f"| {r['lights']} | {r['width']}x{r['height']} | {_fmt(r['ms_median'])} |"
            f" {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} | {_passes(r)} |"
            for r in frames
        ]
    spheres = [r for r in members if r["case"] == SPHERES_CASE]
    if spheres:
        lines += [
            "",
            f"pyrender on the {SPHERES_CASE} scene (app/bench/spheres.py: icospheres of"
            " subdivision 4 in both), render plus read-back per frame; the ratio is"
            " pyrender/pbs of each round's medians:",
            "",
            "| lights | renderer | ms median | min | max | passes, ms | pyrender / pbs |",
            "|---|---|---|---|---|---|---|",
        ]
        lines += [
            f"| {r['lights']} | {r['variant']} | {_fmt(r['ms_median'])} | {_fmt(r['ms_min'])}"
            f" | {_fmt(r['ms_max'])} | {_passes(r)} | {_ratio_text(r.get('pyrender_over_pbs'))} |"
            for r in spheres
        ]
    return lines


def _pyrender_verdicts(rows: list[dict]) -> list[Verdict]:
    """pbs at least PYRENDER_SPEEDUP_MIN times faster than pyrender on the
    35-sphere scene, per light count measured."""
    out = []
    for r in rows:
        if r["case"] != SPHERES_CASE or r["variant"] == SPHERES_PYRENDER:
            continue
        ratio = r["pyrender_over_pbs"]
        out.append(
            Verdict(f"pbs >= {PYRENDER_SPEEDUP_MIN:g}x faster than pyrender, {SPHERES_CASE},"
                    f" {r['lights']} light(s), {r['width']}x{r['height']}, frame + read-back",
                    f"pyrender/pbs = {_ratio_text(ratio)}",
                    _status(ratio["median"] >= PYRENDER_SPEEDUP_MIN))
        )  # fmt: skip
    return out


def _batch_lines(members: list[dict]) -> list[str]:
    """The batch suite's table (images/s median and range over rounds) and its ratios."""
    header = ["orbit", "way", "images/s", "min", "max", "ms per image (whole run)",
              "ms per image (warm)", "images", "rounds"]  # fmt: skip
    rows = []
    for r in members:
        if r.get("images_per_s") is None:
            rows.append([r["case"], r["variant"], f"not measured: {r['not_measured']}"]
                        + [""] * 6)  # fmt: skip
            continue
        rows.append([
            f"{r['case']} ({r['width']}x{r['height']})", r["variant"],
            _fmt(r["images_per_s"], ".2f"), _fmt(r["images_per_s_min"], ".2f"),
            _fmt(r["images_per_s_max"], ".2f"), _fmt(r["ms_median"], ".0f"),
            _fmt(r["steady_ms_median"], ".0f"), str(r["frames"]), str(r["rounds"]),
        ])  # fmt: skip
    lines = table_lines(header, rows)
    ratios = next((r["ratios"] for r in members if "ratios" in r), {})
    lines += ["", "Ratios, this run:", ""]
    lines += [f"- {name}: {_fmt(v, '.2f')}" for name, v in ratios.items()]
    return lines


def _ibl_lines(rows: list[dict], members: list[dict]) -> list[str]:
    """The ibl suite's table: per environment and (face size, samples), the prefilter's
    time and GPU memory, the frame time and the error against the brute-force image, and
    whether the choice is on that environment's time-vs-error front."""
    fronts = pareto_by_comparison(rows, "ibl")
    lines = [
        "| environment | face | samples | default | prefilter ms | cube maps MiB | ms median"
        " | min | max | rel_rmse | FLIP | on front |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in members:
        front = fronts.get(r["case"], {}).get("front", [])
        lines.append(
            f"| {r['case']} | {r['face_size']} | {r['samples']} |"
            f" {'yes' if r.get('default') else ''} | {_fmt(r['prefilter_ms'])} |"
            f" {r['prefilter_bytes'] / 2**20:.2f} | {_fmt(r['ms_median'])} |"
            f" {_fmt(r['ms_min'])} | {_fmt(r['ms_max'])} | {_fmt(r['rel_rmse'], '.3f')} |"
            f" {_fmt(r['flip_mean'], '.3f')} | {'yes' if r['variant'] in front else 'no'} |"
        )
    lines.append("")
    for case, front in fronts.items():
        lines.append(f"- **{case}**: front {', '.join(front['front'])}.")
        for variant, why in front["why"].items():
            lines.append(f"  - '{variant}' is dominated: {why}.")
    return lines


def write_markdown(path: Path, text: str) -> None:
    atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


# --- docs/performance.md's generated section ----------------------------------------------------

DOC_BEGIN = (
    "<!-- begin generated: scripts/performance_doc.py writes this section from a bench.json;"
    " edit the generator, not the text -->"
)
DOC_END = "<!-- end generated -->"


def _row_ms(rows: list[dict], suite: str, variant: str, lights: int) -> float | None:
    row = find(rows, suite, variant, lights)
    return row["ms_median"] if row else None


def _div(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b else None


def _doc_header(payload: dict) -> list[str]:
    m = payload["machine"]
    load = (
        f"{m['load_avg_start'][0]:.1f} at the start, {m['load_avg_end'][0]:.1f} at the end"
        if m.get("load_avg_end")
        else f"{m['load_avg_start'][0]:.1f} at the start"
    )
    gl_version = str(m.get("gl_version", "")).split("Mesa")[-1].strip()
    lines = [
        "## Results",
        "",
        f"The last run: `pbs bench` in **{m['mode']}** mode on {m['date'][:10]} at git"
        f" {m['git']}: {m['cpu']}, {m['cores_usable']} usable cores, {m['gl_renderer']}"
        f"{', Mesa ' + gl_version if gl_version else ''}, through {m['gl_backend'].upper()};"
        f" 1-minute load {load}; {m.get('wall_s', 0):.0f} s in all. Settings:"
        f" {payload.get('settings', '-')}.",
        "",
    ]
    if m["mode"] != "full":
        lines += [
            "The targets are stated for the full mode (the culling suite at 1280×720, up to"
            " 20 s of frames per row): in this mode a smaller image weighs each pass's fixed"
            " cost more and fewer frames leave more noise, so a verdict is indicative and a"
            " Pareto verdict can turn on a difference inside the rows' min–max spread.",
            "",
        ]
    return lines


def _doc_targets(rows: list[dict]) -> list[str]:
    """The verdicts; those of the Pareto fronts in one row (bench.md has each)."""
    lines = ["### Targets", "", "| target | measured | result |", "| --- | --- | --- |"]
    fronts = []
    for v in evaluate_targets(rows):
        if v.target.startswith("default of accuracy"):
            fronts.append(v)
            continue
        lines.append(f"| {v.target} | {v.measured} | {v.status} |")
    if fronts:
        off = [v for v in fronts if v.status != "PASS"]
        measured = f"{len(fronts) - len(off)} of {len(fronts)} on their fronts" + "".join(
            f"; {v.target.split(chr(39))[1]}: {v.measured}" for v in off
        )
        lines.append(
            f"| every default approximation on its accuracy comparison's Pareto front |"
            f" {measured} | {'PASS' if not off else 'FAIL'} |"
        )
    return [*lines, ""]


def _doc_culling(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "culling" and r["case"] != SPHERES_CASE]
    if not members:
        return []
    w, h = members[0]["width"], members[0]["height"]
    counts = sorted({r["lights"] for r in members if r["variant"] == "culled"})
    lines = [
        f"### culling ({w}×{h}, ms per frame to the HDR image)",
        "",
        "| lights | culled | floor | limit | unculled | forward | culled/floor |"
        " unculled/culled | forward/culled | lights per pixel (tile lists) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for n in counts:
        ms = {v: _row_ms(rows, "culling", v, n) for v in CULLING_DOC_VARIANTS}
        culled = find(rows, "culling", "culled", n) or {}
        tile = culled.get("lights_per_tile_mean")
        lines.append(
            f"| {n} | {' | '.join(_fmt(ms[v]) for v in CULLING_DOC_VARIANTS)} |"
            f" {_fmt(_div(ms['culled'], ms['floor']), '.2f')} |"
            f" {_fmt(_div(ms['unculled'], ms['culled']), '.2f')} |"
            f" {_fmt(_div(ms['forward'], ms['culled']), '.2f')} |"
            f" {_fmt(culled.get('lights_per_pixel'), '.2f')}"
            f" ({_fmt(tile, '.1f')}) |"
        )
    lines.append("")
    for r in (r for r in members if r["variant"] == "frame"):
        lines += [
            f"The fixed cost, the whole {r['lights']}-light frame to the caller's 8-bit image"
            f" at {r['width']}×{r['height']}: {r['ms_median']:.1f} ms ({_passes_plain(r)}).",
            "",
        ]
    spheres = [r for r in rows if r["case"] == SPHERES_CASE and r["variant"] != SPHERES_PYRENDER]
    for r in spheres:
        pyr = next(
            (p for p in rows if p["case"] == SPHERES_CASE and p["variant"] == SPHERES_PYRENDER
             and p["lights"] == r["lights"]),
            None,
        )  # fmt: skip
        lines.append(
            f"- {SPHERES_CASE}, {r['lights']} light(s), {r['width']}×{r['height']}: pbs"
            f" {r['ms_median']:.1f} ms, pyrender {_fmt(pyr and pyr['ms_median'])} ms,"
            f" pyrender/pbs {_ratio_text(r.get('pyrender_over_pbs'))}."
        )
    return [*lines, ""] if spheres else lines


CULLING_DOC_VARIANTS = ("culled", "floor", "limit", "unculled", "forward")


def _passes_plain(row: dict) -> str:
    wall = row.get("passes_ms") or {}
    return " + ".join(f"{name} {ms:.1f}" for name, ms in wall.items()) or "-"


def _doc_resolution(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "resolution"]
    if not members:
        return []
    lines = [
        f"### resolution ({members[0]['lights']} lights, culled)",
        "",
        "| size | ms median | passes, ms | ns per pixel |",
        "| --- | --- | --- | --- |",
    ]
    for r in members:
        per_px = r["ms_median"] * 1e6 / (r["width"] * r["height"])
        lines.append(
            f"| {r['width']}×{r['height']} | {r['ms_median']:.1f} | {_passes_plain(r)} |"
            f" {per_px:.0f} |"
        )
    return [*lines, ""]


def _doc_accuracy(rows: list[dict]) -> list[str]:
    fronts = pareto_by_comparison(rows)
    if not fronts:
        return []
    lines = [
        "### accuracy",
        "",
        "Defaults in bold; error against the float64 twin of the exact form (the ray-caster"
        " for `primitives`, an 8×8-supersampled image for `mip_filtering`).",
        "",
        "| comparison | variant | ms median | lighting ms | rel_rmse | FLIP | on front |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for comp, front in fronts.items():
        for i, r in enumerate(front["rows"]):
            name = f"**{r['variant']}**" if r.get("default") else r["variant"]
            lighting = (r.get("passes_ms") or {}).get("lighting")
            lines.append(
                f"| {comp if i == 0 else ''} | {name} | {_fmt(r['ms_median'])} |"
                f" {_fmt(lighting)} | {_fmt(r['rel_rmse'], '.2e')} |"
                f" {_fmt(r['flip_mean'], '.2e')} |"
                f" {'yes' if r['variant'] in front['front'] else 'no'} |"
            )
    return [*lines, ""]


def _doc_specialization(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "specialization"]
    if not members:
        return []
    lines = [
        "### specialization",
        "",
        "| scene | variant | lighting programs | ms median | lighting ms | uber/specialized |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in members:
        ratio = specialization_ratio(rows, r["case"]) if r["variant"] == "uber" else None
        lines.append(
            f"| {r['case']} | {r['variant']} | {r.get('lighting_programs', '-')} |"
            f" {_fmt(r['ms_median'])} | {_fmt((r.get('passes_ms') or {}).get('lighting'))} |"
            f" {_fmt(ratio, '.2f')} |"
        )
    return [*lines, ""]


def _doc_startup_phases(row: dict) -> list[str]:
    """The cold start step by step (app/bench/startup_phases.py): a table of medians."""
    lines = [
        "",
        f"The cold start of {row['case']} step by step (medians of {row['frames']} runs,"
        " wall and CPU time of the process, all its threads):",
        "",
        "| step | wall ms | CPU ms |",
        "| --- | --- | --- |",
    ]
    for name, wall, cpu in row["phases"]:
        lines.append(f"| {name} | {wall * 1e3:.0f} | {cpu * 1e3:.0f} |")
    total_cpu = sum(p[2] for p in row["phases"]) * 1e3
    lines.append(f"| all | {row['ms_median']:.0f} | {total_cpu:.0f} |")
    lines += [
        "",
        f"Compiling and linking its {row['programs']} programs (Mesa's shader cache warm):"
        f" {row['programs_ms']:.0f} ms of the Renderer() and first-frame steps.",
        "",
    ]
    return lines


def _doc_startup_viewer(rows: list[dict]) -> list[str]:
    """Cold start, the API's frames and the viewer's waits, a line each."""
    lines = []
    start = [r for r in rows if r["suite"] == "startup"]
    if start:
        lines += ["### startup and viewer", ""]
        lines += [
            f"- {r['case']}, {r['variant']}: {r['ms_median']:.0f} ms"
            + (f", peak RSS {r['peak_rss_mib']:.0f} MiB" if r.get("peak_rss_mib") else "")
            + (f", CPU {r['cpu_ms_median']:.0f} ms" if r.get("cpu_ms_median") else "")
            + f" (n = {r['frames']})"
            for r in start
            if not r.get("phases")
        ]
        for r in (r for r in start if r.get("phases")):
            lines += _doc_startup_phases(r)
    view = [r for r in rows if r["suite"] == "viewer" and r["variant"] != "idle"]
    idle = _viewer_idle(rows)
    if view:
        if not start:
            lines += ["### startup and viewer", ""]
        waits = "; ".join(
            f"{r['variant']} {r['ms_median']:.0f} (p95 {_fmt(r.get('ms_p95'), '.0f')})"
            for r in view
        )
        lines.append(
            f"- viewer, an input's wait for its image in a {view[0]['width']}×"
            f"{view[0]['height']} window, ms median: {waits}"
        )
    if idle is not None:
        lines.append(
            f"- viewer, idle: {idle['cpu_percent']:.2f} % of a core,"
            f" {idle['frames']} frames drawn ({idle['timer']})"
        )
    return [*lines, ""] if lines else []


def _doc_batch(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "batch"]
    if not members:
        return []
    lines = [
        f"### batch ({members[0]['case']})",
        "",
        "| way | images/s (min–max over rounds) | ms per image, warm |",
        "| --- | --- | --- |",
    ]
    for r in members:
        if r.get("images_per_s") is None:
            lines.append(f"| {r['variant']} | not measured: {r.get('not_measured', '-')} | |")
            continue
        lines.append(
            f"| {r['variant']} | {r['images_per_s']:.2f} ({r['images_per_s_min']:.2f}–"
            f"{r['images_per_s_max']:.2f}) | {_fmt(r.get('steady_ms_median'), '.0f')} |"
        )
    ratios = batch_ratios(rows)
    measured = [f"{name} {v:.2f}" for name, v in ratios.items() if v is not None]
    if measured:
        lines += ["", "Ratios: " + "; ".join(measured) + "."]
    return [*lines, ""]


def _doc_ibl(rows: list[dict]) -> list[str]:
    """Per environment: the renderer's prefilter choice, the spread of the error over all
    choices, and the time-vs-error front (bench.md lists every choice)."""
    fronts = pareto_by_comparison(rows, "ibl")
    if not fronts:
        return []
    lines = [
        "### ibl (prefilter: level-0 face size and GGX samples)",
        "",
        "| environment | the renderer's choice | its prefilter ms, cube maps MiB, rel_rmse |"
        " rel_rmse over all choices | front |",
        "| --- | --- | --- | --- | --- |",
    ]
    for case, front in fronts.items():
        default = next((r for r in front["rows"] if r.get("default")), front["rows"][0])
        errors = [r["rel_rmse"] for r in front["rows"]]
        lines.append(
            f"| {case} | {default['face_size']}, {default['samples']} |"
            f" {_fmt(default['prefilter_ms'])}, {default['prefilter_bytes'] / 2**20:.2f},"
            f" {default['rel_rmse']:.3f} | {min(errors):.3f}–{max(errors):.3f} |"
            f" {'; '.join(front['front'])} |"
        )
    return [*lines, ""]


def _doc_antialiasing(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "antialiasing"]
    if not members:
        return []
    size = f"{members[0]['width']}×{members[0]['height']}"
    return [
        f"### antialiasing ({size}: time against the aliased frame, error against the"
        " renderer's 4×4 and 8×8 supersampled frames; docs/antialiasing.md)",
        "",
        *_aa_lines(members),
        "",
    ]


def _doc_transmission(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "transmission"]
    if not members:
        return []
    size = f"{members[0]['width']}×{members[0]['height']}"
    lines = [
        f"### transmission ({size}: the frame with the glass sphere against the same frame"
        " without it, error against exact refraction; docs/transmission.md)",
        "",
        "| sphere | ms median | without it | rel_rmse | largest rel. error | unseen |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in members:
        lines.append(
            f"| {r['case']} | {r['ms_median']:.1f} | {r['opaque_ms_median']:.1f} | "
            f"{r['rel_rmse']:.2g} | {r['max_rel_err']:.3g} | {r['unseen']:.2f} |"
        )
    return [*lines, ""]


def _doc_shadows(rows: list[dict]) -> list[str]:
    members = [r for r in rows if r["suite"] == "shadows"]
    if not members:
        return []
    sizes = sorted({r["shadow_resolution"] for r in members if r.get("shadow_resolution")})
    lines = [
        f"### shadows ({members[0]['width']}×{members[0]['height']}: ms per frame, lit/unlit"
        " mismatch against the ray-caster)",
        "",
        "| light | filter | no shadow | " + " | ".join(f"map {n}" for n in sizes) + " |",
        "| --- | --- | --- | " + " | ".join("---" for _ in sizes) + " |",
    ]
    for case in dict.fromkeys(r["case"] for r in members):
        of_case = [r for r in members if r["case"] == case]
        off = next((r for r in of_case if r.get("mismatch") is None), None)
        filters = dict.fromkeys(
            r["shadow_filter"] for r in of_case if r.get("mismatch") is not None
        )
        for i, name in enumerate(filters):
            cells = []
            for n in sizes:
                r = next(
                    (
                        r
                        for r in of_case
                        if r.get("shadow_filter") == name and r.get("shadow_resolution") == n
                    ),
                    None,
                )
                cells.append(f"{r['ms_median']:.1f}, {r['mismatch']:.1e}" if r else "-")
            first = _fmt(off["ms_median"]) if off and i == 0 else ""
            lines.append(
                f"| {case if i == 0 else ''} | {name} | {first} | " + " | ".join(cells) + " |"
            )
    return [*lines, ""]


def performance_section(payload: dict) -> str:
    """The generated part of docs/performance.md from one bench.json: the run, the targets'
    verdicts, and a compact table per suite that ran (bench.md has every column)."""
    rows = payload["rows"]
    lines = _doc_header(payload) + _doc_targets(rows)
    for part in (
        _doc_culling, _doc_resolution, _doc_accuracy, _doc_specialization, _doc_startup_viewer,
        _doc_batch, _doc_ibl, _doc_shadows, _doc_assets, _doc_antialiasing, _doc_transmission,
        _doc_peers,
    ):  # fmt: skip
        lines += part(rows)
    notes = [n for n in payload.get("notes", []) if n]
    if notes:
        lines += ["Notes of the run: " + " ".join(n.rstrip(".") + "." for n in notes), ""]
    return "\n".join(lines).rstrip() + "\n"


def replace_generated(doc: str, section: str, begin: str = DOC_BEGIN, end: str = DOC_END) -> str:
    """``doc`` with the text between the ``begin`` and ``end`` markers replaced by
    ``section``; a doc without both markers, in that order, is an error rather than a
    silent append."""
    first, last = doc.find(begin), doc.find(end)
    if first < 0 or last < 0 or last < first:
        raise ValueError(f"the markers {begin!r} and {end!r} are not both there, in order")
    return f"{doc[: first + len(begin)]}\n{section}{doc[last:]}"


def update_generated(
    tool: str, doc: Path, section: str, source: object, check: bool, markers: tuple[str, str]
) -> int:
    """A doc-generating script's end: put ``section`` between ``markers`` in ``doc``, or
    with ``check`` only compare; the exit code (0, 1 when ``check`` finds the doc stale,
    2 when the markers are missing), each outcome one line naming ``tool`` and the doc."""
    old = doc.read_text(encoding="utf-8")
    try:
        new = replace_generated(old, section, *markers)
    except ValueError as exc:
        print(f"{tool}: {doc}: {exc}", file=sys.stderr)
        return 2
    if check:
        if new != old:
            print(f"{tool}: {doc}'s generated section differs from {source}")
            return 1
        return 0
    doc.write_text(new, encoding="utf-8")
    print(f"{tool}: {doc} written from {source}")
    return 0
