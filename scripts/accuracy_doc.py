"""docs/accuracy.md's every-pixel tables: the renderer against the pixel-area-integrated
float64 ray-cast, every pixel, under a list of settings.

    python scripts/accuracy_doc.py [--setting OVERRIDES]... [--json FILE] [--width W]
                                   [--scenes NAME...] [--jobs 2]
    python scripts/accuracy_doc.py --from-json FILE [--check]

The first measures (app/bench/raycast.py ``every_pixel_row``): the five-sphere scene and
every bundled scene of analytic primitives lit by punctual lights (``analytic_scenes``,
shadows off), each at its own render size (``--width W``: W pixels wide instead), against
``area_reference_scene``'s truth, once
per ``--setting`` (comma-separated SECTION.KEY=VALUE overrides; "" is the scene's own
settings, "defaults"); it writes the JSON (default docs/accuracy_every_pixel.json) and the
doc's generated section from it. The second rewrites the section from a JSON, or with
``--check`` writes nothing and exits 1 where the doc's section differs from it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from app.bench.raycast import (
    analytic_scenes,
    every_pixel_row,
    five_spheres,
    parse_overrides,
    settings_label,
    truth_errors,
    unshadowed,
)
from app.bench.report import update_generated
from app.frame.raycast import area_reference_scene
from app.reference.raycast import RaycastImage
from app.scene.loader import LoadedScene, load_scene

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy.md"
JSON = ROOT / "docs" / "accuracy_every_pixel.json"
# The rows of the table: the defaults, gbaa without its interior correction, the aliased
# frame and a 4 x 4 box-filtered one.
SETTINGS = [
    "", "render.gbaa_interior=false", "render.antialiasing=none",
    "render.antialiasing=none,render.supersample=4",
]  # fmt: skip
TARGET_FLIP = 1e-3  # mean FLIP over every pixel (docs/accuracy.md)
BEGIN = "<!-- begin generated: scripts/accuracy_doc.py writes this section; edit the script -->"
END = "<!-- end generated: scripts/accuracy_doc.py -->"
CHANGES_IMAGE = {"render.terms", "render.width", "render.height"}  # the truth would differ
# The truth checked by a finer one (twice the rays per side: four times the cost)
CONVERGENCE = ["five spheres"]


def _scene(name: str) -> LoadedScene:
    """The measured scene ``name``: the five spheres, or a bundled scene without shadows."""
    if name == "five spheres":
        return five_spheres()
    return unshadowed(load_scene(ROOT / "scenes" / f"{name}.toml"))


def _size(loaded: LoadedScene, width: int | None) -> tuple[int, int]:
    """The scene's own render size (``width`` None), else ``width`` at its aspect."""
    render = loaded.scene.render
    if width is None:
        return (render.width, render.height)
    return (width, max(8, round(width * render.height / render.width)))


def _truth(
    loaded: LoadedScene,
    name: str,
    size: tuple[int, int],
    samples: int,
    edge: int,
    cache: Path | None,
) -> RaycastImage:
    """``area_reference_scene`` of ``loaded`` at ``size``, read from ``cache`` (a folder of
    .npz files named by scene, size and rays) where it holds it, else computed and stored
    there: the truth is the scene's alone, so reruns that change the renderer reuse it."""
    path = None
    if cache is not None:
        stem = f"{name.replace(' ', '_')}_{size[0]}x{size[1]}_{samples}_{edge}"
        path = cache / f"{stem}.npz"
        if path.is_file():
            with np.load(path) as d:
                return RaycastImage(d["hdr"], d["covered"], d["ids"])
    truth = area_reference_scene(loaded, size, samples, edge)
    if path is not None:
        cache.mkdir(parents=True, exist_ok=True)
        np.savez(path, hdr=truth.hdr, covered=truth.covered, ids=truth.ids)
    return truth


def _truths(
    name: str, width: int | None, samples: int, edge: int, cache: Path | None = None
) -> tuple:
    """The truth of scene ``name`` and, for the CONVERGENCE scenes, a finer one (None
    otherwise): a worker process's job."""
    loaded = _scene(name)
    size = _size(loaded, width)
    truth = _truth(loaded, name, size, samples, edge, cache)
    finer = None
    if name in CONVERGENCE:
        finer = _truth(loaded, name, size, 2 * samples, 2 * edge, cache)
    return truth, finer


def measure(args: argparse.Namespace) -> dict:
    from app.gl.context import create_context

    overrides = [parse_overrides(s) for s in args.setting or SETTINGS]
    for o in overrides:
        for key in o:
            if not key.startswith("render.") or key in CHANGES_IMAGE:
                raise ValueError(
                    f"setting {key}: only render.* keys that change how the image is"
                    " sampled (the truth is the scene's)"
                )
    names = ["five spheres"] + [p.stem for p in analytic_scenes(ROOT / "scenes")]
    if args.scenes:
        unknown = sorted(set(args.scenes) - set(names))
        if unknown:
            raise ValueError(f"--scenes: not a measured scene: {', '.join(unknown)}")
        names = [n for n in names if n in args.scenes]
    # The cheapest truths first (pixels times primitives), so that a run stopped early
    # (--json is written after every scene) holds the most scenes.
    names.sort(key=lambda n: _cost(_scene(n), args.width))
    start = time.perf_counter()
    payload: dict = {
        "width": args.width,
        "samples": args.samples,
        "edge_samples": args.edge_samples,
        "settings": [settings_label(o) for o in overrides],
        "rows": [],
        "convergence": [],
        "unmeasured": list(names),
        "seconds": 0.0,
        "cached": 0,  # truths read from --cache (their time is not in "seconds")
    }
    _write_json(args.json, payload)
    # The truths (numpy, one core each) in worker processes; the renders here, as each
    # truth arrives
    cached = {n for n in names if _cached(n, args)}
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        jobs = {
            pool.submit(_truths, n, args.width, args.samples, args.edge_samples, args.cache): n
            for n in names
        }
        gl = create_context(args.backend)
        try:
            for job in as_completed(jobs):
                name = jobs[job]
                truth, finer = job.result()
                loaded = _scene(name)
                size = _size(loaded, args.width)
                cam, render = loaded.scene.camera, loaded.scene.render
                for o in overrides:
                    e = every_pixel_row(gl, loaded, size, truth, o)
                    label = settings_label(o)
                    payload["rows"].append(
                        {"scene": name, "size": list(size), "settings": label, **e}
                    )
                if finer is not None:
                    e = truth_errors(truth, finer, cam.exposure, render.tonemap)
                    payload["convergence"].append({"scene": name, "size": list(size), **e})
                payload["unmeasured"].remove(name)
                payload["cached"] += int(name in cached)
                payload["seconds"] = round(time.perf_counter() - start, 1)
                _write_json(args.json, payload)
                print(f"accuracy_doc: {name} {size[0]}x{size[1]}", file=sys.stderr, flush=True)
        finally:
            gl.release()
    return payload


def _cached(name: str, args: argparse.Namespace) -> bool:
    """Whether ``args.cache`` holds the truth of scene ``name`` (``_truth``'s file)."""
    if args.cache is None:
        return False
    w, h = _size(_scene(name), args.width)
    stem = f"{name.replace(' ', '_')}_{w}x{h}_{args.samples}_{args.edge_samples}"
    return (args.cache / f"{stem}.npz").is_file()


def _cost(loaded: LoadedScene, width: int | None) -> int:
    """A truth's relative cost: its pixels times its objects."""
    w, h = _size(loaded, width)
    return w * h * max(1, len(loaded.scene.objects))


def _write_json(path: Path, payload: dict) -> None:
    """``payload`` with its rows in scene order (the five spheres first), to ``path``."""

    def scene(r: dict) -> str:
        return "" if r["scene"] == "five spheres" else r["scene"]

    out = {
        **payload,
        "rows": sorted(
            payload["rows"], key=lambda r: (scene(r), payload["settings"].index(r["settings"]))
        ),
        "convergence": sorted(payload["convergence"], key=scene),
    }
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")


def _f(x: float | None) -> str:
    return "–" if x is None else f"{x:.2e}"


def _where(payload: dict) -> str:
    """ "each scene at its own size" or "160 pixels wide"."""
    width = payload.get("width")
    return "each scene at its own size" if width is None else f"{width} pixels wide"


def _shown(r: dict) -> float:
    """A row's verdict number: its 8-bit display FLIP (the image the user gets), the HDR
    FLIP where a JSON has none."""
    d = r.get("display_flip_mean")
    return r["flip_mean"] if d is None else d


def section(payload: dict) -> str:
    """The generated Markdown: the verdict per setting, the per-scene table (each setting's
    8-bit display FLIP, the defaults' split into edge and interior pixels and their verdict),
    the truth's convergence and the full table."""
    n, e = payload["samples"], payload["edge_samples"]
    names = list(dict.fromkeys(r["scene"] for r in payload["rows"]))
    lines = [
        f"Truth: {n} × {n} multi-jittered rays per pixel, {e} × {e} on edge pixels and"
        " sub-pixel highlights;"
        f" {_where(payload)}; {len(names)} scenes;"
        f" {payload['seconds']:.0f} s on llvmpipe (EGL), 2 cores"
        + (f" ({payload['cached']} truths read from a cache)." if payload.get("cached") else "."),
        "",
        "| settings | 8-bit display FLIP, mean over scenes | worst scene |"
        f" scenes ≤ {TARGET_FLIP:.0e} | HDR FLIP, mean over scenes | rel RMSE, mean over scenes |",
        "|---|---|---|---|---|---|",
    ]
    for label in payload["settings"]:
        rows = [r for r in payload["rows"] if r["settings"] == label]
        shown = [_shown(r) for r in rows]
        worst = max(rows, key=_shown)
        ok = sum(f <= TARGET_FLIP for f in shown)
        flips = [r["flip_mean"] for r in rows]
        rmse = [r["rel_rmse"] for r in rows if r["rel_rmse"] is not None]
        lines.append(
            f"| {label} | {sum(shown) / len(shown):.2e} | {_shown(worst):.2e}"
            f" (`{worst['scene']}`) | {ok} of {len(rows)} |"
            f" {sum(flips) / len(flips):.2e} |"
            f" {_f(sum(rmse) / len(rmse) if rmse else None)} |"
        )
    defaults = {r["scene"]: r for r in payload["rows"] if r["settings"] == "defaults"}
    if defaults:
        shown = sum(_shown(r) for r in defaults.values()) / len(defaults)
        verdict = "PASS" if shown <= TARGET_FLIP else "FAIL"
        ok = sum(_shown(r) <= TARGET_FLIP for r in defaults.values())
        lines += [
            "",
            f"**{verdict}**: the target (the defaults' 8-bit display FLIP against the area"
            f" truth, mean over the {len(defaults)} scenes measured, ≤ {TARGET_FLIP:.0e}),"
            f" {_where(payload)}:"
            f" {shown:.2e}, {shown / TARGET_FLIP:.2f}× the target; {ok} of {len(defaults)}"
            " scenes within it on their own.",
        ]
    if payload.get("unmeasured"):
        missing = ", ".join(f"`{n}`" for n in payload["unmeasured"])
        lines += [
            "",
            f"Not measured (the run was stopped before their truths were done): {missing}.",
        ]
    others = [label for label in payload["settings"] if label != "defaults"]
    head = " | ".join(others)
    lines += [
        "",
        "8-bit display FLIP per scene (the defaults' edge / interior pixels in brackets,"
        " the verdict the defaults'):",
        "",
        f"| scene | size | edge pixels | defaults (edge / interior) | {head} |"
        f" defaults ≤ {TARGET_FLIP:.0e} |",
        "|---|---|---|---|" + "---|" * len(others) + "---|",
    ]
    for name in names:
        rows = {r["settings"]: r for r in payload["rows"] if r["scene"] == name}
        d = rows.get("defaults")
        if d is None:
            continue
        cells = " | ".join(_f(_shown(rows[label])) if label in rows else "–" for label in others)
        verdict = "PASS" if _shown(d) <= TARGET_FLIP else "FAIL"
        lines.append(
            f"| `{name}` | {d['size'][0]}×{d['size'][1]} | {100 * d['edge_share']:.1f} % |"
            f" {_f(_shown(d))} ({_f(d.get('display_flip_edge'))} /"
            f" {_f(d.get('display_flip_interior'))}) | {cells} | {verdict} |"
        )
    lines += [
        "",
        f"The truth against one with twice the rays per side ({2 * n} × {2 * n},"
        f" {2 * e} × {2 * e} on edges):",
        "",
        "| scene | size | mean FLIP | edge FLIP | interior FLIP | rel RMSE |",
        "|---|---|---|---|---|---|",
    ]
    for c in payload["convergence"]:
        lines.append(
            f"| `{c['scene']}` | {c['size'][0]}×{c['size'][1]} | {_f(c['flip_mean'])} |"
            f" {_f(c['flip_edge'])} | {_f(c['flip_interior'])} | {_f(c['rel_rmse'])} |"
        )
    lines += [
        "",
        "| scene | size | settings | HDR FLIP | edge FLIP | interior FLIP | 8-bit display FLIP"
        " | rel RMSE | edge rel RMSE | edge pixels |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        lines.append(
            f"| `{r['scene']}` | {r['size'][0]}×{r['size'][1]} | {r['settings']} |"
            f" {_f(r['flip_mean'])} | {_f(r['flip_edge'])} | {_f(r['flip_interior'])} |"
            f" {_f(r['display_flip_mean'])} | {_f(r['rel_rmse'])} | {_f(r['rel_rmse_edge'])} |"
            f" {100 * r['edge_share']:.1f} % |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--setting",
        action="append",
        help='overrides of one row, e.g. "render.supersample=4" ("" for the defaults);'
        " repeat for more rows (default: defaults, supersample 2, supersample 4)",
    )
    parser.add_argument("--json", type=Path, default=JSON, help="the measurements' JSON")
    parser.add_argument("--from-json", type=Path, help="write (or --check) the doc from a JSON")
    parser.add_argument("--check", action="store_true", help="with --from-json: exit 1 if stale")
    parser.add_argument("--doc", type=Path, default=DOC)
    parser.add_argument(
        "--width", type=int, help="every scene this many pixels wide (default: its own size)"
    )
    parser.add_argument("--samples", type=int, default=4, help="truth: n x n rays per pixel")
    parser.add_argument("--edge-samples", type=int, default=32, help="truth: on edge pixels")
    parser.add_argument("--backend", default="egl", choices=["egl", "osmesa"])
    parser.add_argument("--scenes", nargs="+", help='only these ("five spheres", file stems)')
    parser.add_argument("--jobs", type=int, default=2, help="processes computing the truths")
    parser.add_argument("--cache", type=Path, help="a folder keeping the truths (.npz) for reruns")
    args = parser.parse_args(argv)
    if args.from_json is not None:
        payload = json.loads(args.from_json.read_text(encoding="utf-8"))
    else:
        try:
            measure(args)
        except ValueError as exc:
            print(f"accuracy_doc: {exc}", file=sys.stderr)
            return 2
        payload = json.loads(args.json.read_text(encoding="utf-8"))
    source = args.from_json or args.json
    return update_generated(
        "accuracy_doc", args.doc, section(payload), source, args.check, (BEGIN, END)
    )


if __name__ == "__main__":
    sys.exit(main())
