"""The bench's suites: what is rendered, how it is timed, what each row holds.

Every row has ``suite``, ``case``, ``variant``, ``width``, ``height``, ``lights``,
``ms_median``, ``ms_min``, ``ms_max`` (wall clock per frame, glFinish to glFinish),
``frames``, ``passes_ms`` (median wall time per pass, each ended by glFinish),
``passes_gpu_ms`` (median GL_TIME_ELAPSED per pass where every frame's was plausible),
``passes_submit_ms`` (time for the pass's calls to return), ``timer``, ``load_1min``
(os.getloadavg() as the row finished) and, where the image has a float64 reference,
``rel_rmse``, ``max_rel_err``, ``flip_mean`` (app/bench/metrics.py); None elsewhere.

A frame ends at the linear HDR image: the post pass (tone map to 8 bits), the same for
every deferred variant and absent from the forward one, is not in it.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.bench.area_lights import run_area_lights
from app.bench.context import (
    Context,
    Settings,
    api_mesh_scene,
    deferred_passes,
    make_row,
    pyrender_env,
)
from app.bench.encodings import channel_errors
from app.bench.filtering import OPTIONS as FILTER_OPTIONS
from app.bench.filtering import SWEEP_METRES, render_hdr, shimmer, with_settings
from app.bench.floor import FloorPass
from app.bench.forward import ForwardRenderer
from app.bench.limit import LimitPass
from app.bench.metrics import image_errors, interior_errors
from app.bench.pairs import LightPairs, light_pairs, reference_hdr
from app.bench.raycast import five_spheres, scene_with_spheres
from app.bench.scenes import (
    SPECIALIZATION_KINDS,
    accuracy_scene,
    encoding_scene,
    load,
    many_lights_scene,
    specialization_scene,
)
from app.bench.shadows import run_shadows, shadows_tasks
from app.bench.startup import cold_start, quick_answers, startup_phases
from app.bench.timing import (
    Budget,
    Pass,
    round_ratios,
    summary,
)
from app.common.gbuffer import DEFAULT_ENCODING, ENCODING_NAMES
from app.common.tables import DEFAULT_SIZE
from app.frame.raycast import reference_scene
from app.gl.context import GLContext
from app.reference.multiscatter import load_tables
from app.render.culling import TILE_SIZE
from app.render.renderer import Renderer, RenderOptions
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, load_scene

CULLING_VARIANTS = ("culled", "unculled", "forward", "floor", "limit")
FIXED_COST_LIGHTS = 1  # the frame whose fixed costs the "frame" row shows


def f32_reference(gl: GLContext, data: dict, pairs: LightPairs) -> tuple[np.ndarray, np.ndarray]:
    """The float64 twin's image of scene ``data`` on its f32 G-buffer (the unquantised
    surface) over the in-range ``pairs`` (other lights add exactly 0), and the covered
    pixels."""
    exact = Renderer(gl, load({**data, "render": {**data["render"], "gbuffer": "f32"}}))
    try:
        exact.gbuffer_pass.run(exact.gbuffer, exact.view, exact.proj, exact.camera)
        g32 = exact.read_gbuffer()
        ref = reference_hdr(
            g32, exact.camera, exact.lights, exact.scene.background,
            exact.materials.models, exact.materials.packed(), pairs,
        )  # fmt: skip
    finally:
        exact.release()
    return ref, g32.covered


# --- culling and resolution -----------------------------------------------------------------


def _pyrender_request(data: dict, size: tuple[int, int], budget: Budget) -> dict:
    return {
        "scene": data,
        "size": list(size),
        "warmup": budget.warmup,
        "min_frames": budget.min_frames,
        "max_frames": budget.max_frames,
        "seconds": budget.seconds,
    }


def run_pyrender(data: dict, size: tuple[int, int], budget: Budget) -> dict:
    """pyrender in a child process (app/bench/pyrender_child.py); never raises."""
    env = pyrender_env()
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "app.bench.pyrender_child"],
            input=json.dumps(_pyrender_request(data, size, budget)),
            capture_output=True,
            text=True,
            env=env,
            timeout=900,
        )
    except subprocess.TimeoutExpired:
        return {"ok": False, "why": "pyrender child timed out (900 s)"}
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if not lines:
        tail = proc.stderr.strip().splitlines()[-1:] or [f"exit code {proc.returncode}"]
        return {"ok": False, "why": f"pyrender child gave no result: {tail[0]}"}
    return json.loads(lines[-1])


def _culling_case(ctx: Context, count: int, size: tuple[int, int], pyrender: bool) -> None:
    """All variants of one light count, timed interleaved (``time_interleaved``), then
    compared with one reference."""
    gl, progress = ctx.gl, ctx.progress
    light_range = ctx.light_range(count)
    data = many_lights_scene(count, light_range, size)
    loaded = load(data)
    case = f"{count} lights"
    common = {"light_range_m": light_range}
    pending: list[dict] = []
    variants = ", ".join(CULLING_VARIANTS)
    progress.start(f"culling {case}: {variants}, interleaved")
    culled = Renderer(gl, loaded, size)
    unculled = floor = forward = limit = as_given = None
    try:
        # The floor's pairs come from the culled renderer's G-buffer, drawn once here.
        culled.gbuffer_pass.run(culled.gbuffer, culled.view, culled.proj, culled.camera)
        pairs = light_pairs(culled.read_gbuffer(), culled.camera, culled.lights)
        common["lights_per_pixel"] = pairs.mean_per_covered_pixel
        common["lights_per_pixel_max"] = int(pairs.count.max())
        floor = FloorPass(culled, pairs)
        limit = LimitPass(culled, pairs)
        unculled = Renderer(
            gl, load({**data, "render": {**data["render"], "light_culling": "none"}}), size
        )
        forward = ForwardRenderer(gl, loaded, size)
        gb = culled.gbuffer_pass
        frames = {
            "culled": deferred_passes(culled),
            "floor": [
                Pass("gbuffer",
                     lambda: gb.run(culled.gbuffer, culled.view, culled.proj, culled.camera),
                     culled.gbuffer.fbo),
                Pass("floor", floor.run, floor.fbo),
            ],
            "limit": [
                Pass("gbuffer",
                     lambda: gb.run(culled.gbuffer, culled.view, culled.proj, culled.camera),
                     culled.gbuffer.fbo),
                Pass("limit", limit.run, limit.fbo),
            ],
            "unculled": deferred_passes(unculled),
            "forward": [Pass("forward", forward.render, forward.fbo)],
        }  # fmt: skip
        if count == FIXED_COST_LIGHTS:
            # The fixed cost: the whole frame to the caller's 8-bit image, with the
            # scene's default light culling ("auto": no tiles at one light), as a user gets.
            from app.bench.spheres import pbs_frame_passes

            as_given = Renderer(
                gl, load({**data, "render": {**data["render"], "light_culling": "auto"}}), size
            )
            frames["frame"] = pbs_frame_passes(as_given)
        times = ctx.time_interleaved(frames)
        # The floor pass draws into its own target from the shared G-buffer, so each
        # variant's image is read after all of them have run.
        images: dict[str, np.ndarray] = {
            "culled": culled.read_hdr(),
            "floor": floor.read_hdr(),
            "unculled": unculled.read_hdr(),
            "forward": forward.read_hdr(),
        }
        extra = {}
        if culled.culler is not None:
            # What the tiled loop visits: each surface pixel's tile list, averaged like the
            # pairs (masks are bottom-up tile rows; the G-buffer arrays top-down).
            per_tile = culled.culler.read_masks().sum(axis=-1)
            h = pairs.covered.shape[0]
            rows, cols = np.nonzero(pairs.covered)
            tiles_y = (h - 1 - rows) // TILE_SIZE
            extra["lights_per_tile_mean"] = float(per_tile[tiles_y, cols // TILE_SIZE].mean())
        pending += [
            make_row("culling", case, "culled", size, count, times["culled"], **common, **extra),
            make_row("culling", case, "floor", size, count, times["floor"], pairs=pairs.total,
                     **common),
            make_row("culling", case, "unculled", size, count, times["unculled"], **common),
            make_row("culling", case, "forward", size, count, times["forward"], **common),
            make_row("culling", case, "limit", size, count, times["limit"],
                     limit_lights_per_pixel=limit.count, limit_terms=limit.terms,
                     limit_form=limit.form, pairs=pairs.total,
                     culled_over_limit=round_ratios(times["culled"], times["limit"]),
                     culled_over_limit_lighting=round_ratios(
                         times["culled"], times["limit"], ("cull", "lighting"), ("limit",)),
                     **common),
        ]  # fmt: skip
        if "frame" in times:
            pending.append(
                make_row("culling", case, "frame", size, count, times["frame"],
                         frame="G-buffer, cull (where the default light_culling tiles),"
                         " lighting, post, 8-bit read-back", **common)
            )  # fmt: skip
        progress.done()

        if pyrender:
            progress.start(f"culling {case}: culled_readback (to compare with pyrender)")

            def to_pixels() -> None:
                culled.render()
                culled.read_ldr()

            times_rb = ctx.time([Pass("render+read_ldr", to_pixels)])
            pending.append(
                make_row("culling", case, "culled_readback", size, count, times_rb, **common)
            )
            progress.done()
    finally:
        for obj in (as_given, limit, floor, forward, unculled, culled):
            if obj is not None:
                obj.release()

    if pyrender:
        progress.start(f"culling {case}: pyrender (child process)")
        result = run_pyrender(data, size, ctx.settings.budget)
        if result.get("ok"):
            ms = result["ms"]
            med, lo, hi = summary(ms)
            row = make_row(
                "culling", case, "pyrender", size, count, None,
                ms_median=med, ms_min=lo, ms_max=hi, frames=len(ms),
                timer="perf_counter around render() (includes colour+depth read-back)",
                pyrender=result, **common,
            )  # fmt: skip
            pending.append(row)
        else:
            ctx.pyrender = False
            ctx.notes.append(f"pyrender: {result.get('why')}")
        progress.done()

    # One float64 reference for all variants: the twin on an f32 G-buffer of the same view
    # (the unquantised surface), over the in-range pairs (other lights add exactly 0).
    progress.start(f"culling {case}: float64 reference and errors")
    ref, covered = f32_reference(gl, data, pairs)
    cam = loaded.scene.camera
    for row in pending:
        if row["variant"] in images:
            row.update(
                image_errors(images[row["variant"]], ref, covered, cam.exposure,
                             loaded.scene.render.tonemap)
            )  # fmt: skip
        row["error_reference"] = "float64 twin on an f32 G-buffer, in-range pairs"
    ctx.rows.extend(pending)
    progress.done()


def culling_tasks(settings: Settings, pyrender: bool) -> int:
    counts = _culling_counts(settings, pyrender)
    tasks = 0
    for count in counts:
        with_pyrender = pyrender and count in settings.pyrender_lights
        tasks += 2 + (2 if with_pyrender else 0)  # the variants; the reference
    from app.bench.spheres import sphere_tasks

    return tasks + sphere_tasks(settings, pyrender)


def _culling_counts(settings: Settings, pyrender: bool) -> list[int]:
    counts = list(settings.light_counts)
    if pyrender:
        counts += [n for n in settings.pyrender_lights if n not in counts]
    return sorted(counts)


def run_culling(ctx: Context) -> None:
    """Suite ``culling``: culled, unculled, forward, floor and limit at each light count."""
    s = ctx.settings
    for count in _culling_counts(s, ctx.pyrender):
        if count not in s.light_counts and not ctx.pyrender:
            continue  # the extra pyrender case, and pyrender turned out to be unavailable
        _culling_case(ctx, count, s.culling_size, ctx.pyrender and count in s.pyrender_lights)
    if ctx.pyrender:
        from app.bench.spheres import run_pyrender_spheres

        run_pyrender_spheres(ctx)


def run_resolution(ctx: Context) -> None:
    """Suite ``resolution``: the culled pipeline at each image size, 64 lights."""
    s = ctx.settings
    count = s.resolution_lights
    light_range = ctx.light_range(count)
    for size in s.resolutions:
        case = f"{size[0]}x{size[1]}"
        ctx.progress.start(f"resolution {case}: culled")
        r = Renderer(ctx.gl, load(many_lights_scene(count, light_range, size)), size)
        try:
            times = ctx.time(deferred_passes(r))
        finally:
            r.release()
        ctx.rows.append(
            make_row("resolution", case, "culled", size, count, times, light_range_m=light_range)
        )
        ctx.progress.done()


# --- accuracy -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Variant:
    """One way of rendering a comparison's scene."""

    name: str
    model: dict  # material keys given to every material
    default: bool = False
    gbuffer: str = DEFAULT_ENCODING
    ms_size: int | None = None  # multiple-scattering table size (None: the pass's own)


@dataclass(frozen=True)
class Comparison:
    """An approximation against its exact form; ``reference`` is rendered untimed for its
    G-buffer, which the float64 twin then shades (with ``ms_reference`` if set)."""

    name: str
    title: str
    variants: tuple[Variant, ...]
    reference: Variant
    ms_reference: int | None = None
    layered: bool = False  # rendered at Settings.layered_size, not accuracy_size


def comparisons(settings: Settings) -> list[Comparison]:
    """The accuracy suite's comparisons, with the renderer's defaults marked."""
    dielectric = {"ior": 1.5}
    out = [
        Comparison(
            "fresnel",
            "Schlick vs exact Fresnel (dielectric, n = 1.5)",
            (
                Variant("schlick", {"fresnel": "schlick", **dielectric}, default=True),
                Variant("exact", {"fresnel": "dielectric", **dielectric}),
            ),
            Variant("exact", {"fresnel": "dielectric", **dielectric}),
        ),
        Comparison(
            "g2",
            "Hammon vs exact height-correlated Smith G2 (GGX)",
            (
                Variant("hammon", {"g2": "hammon"}),
                Variant("height_correlated", {}, default=True),
            ),
            Variant("height_correlated", {}),
        ),
        Comparison(
            "lambda",
            "Beckmann Lambda: rational vs exact",
            (
                Variant("rational", {"ndf": "beckmann", "lambda_form": "rational"}),
                Variant("exact", {"ndf": "beckmann"}, default=True),
            ),
            Variant("exact", {"ndf": "beckmann"}),
        ),
        Comparison(
            "gbuffer",
            "G-buffer encodings: float16, 16-bit unorm, unorm16 base colour, float32",
            tuple(
                Variant(name, {}, default=name == DEFAULT_ENCODING, gbuffer=name)
                for name in ENCODING_NAMES
            ),
            Variant("f32", {}, gbuffer="f32"),
        ),
        Comparison(
            "ms_table",
            f"Kulla-Conty table size (reference: {settings.ms_reference}x{settings.ms_reference})",
            tuple(
                Variant(f"{n}x{n}", {"multiscatter": True}, default=n == DEFAULT_SIZE, ms_size=n)
                for n in settings.ms_sizes
            ),
            Variant("reference", {"multiscatter": True}, ms_size=settings.ms_reference),
            ms_reference=settings.ms_reference,
        ),
        *layered_comparisons(),
    ]
    return out


# The layers of RTR4 §9.10-9.12 over every material of the accuracy scene: each model's cost
# against the cheaper alternative (no layer, or the cheaper composition), and its error
# against the float64 twin of the comparison's reference variant.
SHEEN = {"sheen_color": [0.8, 0.8, 0.8], "sheen_roughness": 0.5}
FILM = {"thin_film": True, "film_thickness": 350.0, "film_ior": 1.33}
GRATING = {"diffraction": "grating", "grating_period": 1600.0, "grating_depth": 120.0}
COAT = {"clearcoat": 1.0, "clearcoat_roughness": 0.1}
# Fibres are dielectric threads: every sphere of the scene gets index 1.5 (no metal row).
THREAD = {"fresnel": "schlick", "ior": 1.5}
FIBER = {**THREAD, "fiber_rotation": 30.0, "fiber_curvature": 10.0}


def layered_comparisons() -> list[Comparison]:
    """Sheen NDFs and fibres (RTR4 §9.10), the thin film and the grating (§9.11), the
    clear coat's two compositions (§9.12), at ``Settings.layered_size``.

    The twins of the film and the grating are the GLSL's own closed forms in float64
    (their error against the spectral sums is measured in docs/thin-film.md and
    docs/diffraction.md: a spectral twin per pixel and light would take minutes here).
    The coat's reference is Filament's twin, so Weidlich-Wilkie's row measures how far
    the two compositions part (their errors against the random walk are in
    docs/layered.md); likewise Kajiya-Kay's row against Sadeghi's twin."""
    return [
        Comparison(
            "sheen",
            "cloth sheen layer: none vs Charlie vs Ashikhmin (Neubelt-Pettineo visibility)",
            (
                Variant("none", {}),
                Variant("charlie", {"sheen": "charlie", **SHEEN}, default=True),
                Variant("ashikhmin", {"sheen": "ashikhmin", **SHEEN}),
            ),
            Variant("charlie", {"sheen": "charlie", **SHEEN}),
            layered=True,
        ),
        Comparison(
            "thin_film",
            "thin film (350 nm, n = 1.33): the base's Fresnel vs Belcour-Barla's Airy sum",
            (Variant("none", {}), Variant("film", FILM, default=True)),
            Variant("film", FILM),
            layered=True,
        ),
        Comparison(
            "grating",
            "diffraction grating (1600 nm period, 120 nm deep): none vs its orders",
            (Variant("none", {}), Variant("grating", GRATING, default=True)),
            Variant("grating", GRATING),
            layered=True,
        ),
        Comparison(
            "fiber",
            "micro-cylinder threads (dielectric): none vs Kajiya-Kay vs Sadeghi et al. 2013",
            (
                Variant("none", THREAD),
                Variant("kajiya_kay", {"fiber": "kajiya_kay", **FIBER}),
                Variant("sadeghi", {"fiber": "sadeghi", **FIBER}, default=True),
            ),
            Variant("sadeghi", {"fiber": "sadeghi", **FIBER}),
            layered=True,
        ),
        Comparison(
            "clearcoat",
            "clear coat (roughness 0.1): none vs Filament vs Weidlich-Wilkie",
            (
                Variant("none", {}),
                Variant("filament", {"clearcoat_model": "filament", **COAT}, default=True),
                Variant("weidlich_wilkie", {"clearcoat_model": "weidlich_wilkie", **COAT}),
            ),
            Variant("filament", {"clearcoat_model": "filament", **COAT}),
            layered=True,
        ),
    ]


def accuracy_tasks(settings: Settings) -> int:
    # Per comparison: the reference, the variants; mip filtering: the reference, the
    # variants, each variant's camera sweep.
    # The G-buffer channels: two scenes. The primitives: two scenes, each the ray-cast
    # reference and the variants.
    return 2 * len(comparisons(settings)) + len(FILTER_OPTIONS) + 2 + 2 + 4


# The table sizes' scenes are gold with the standard (height-correlated) G2: the other G2
# forms' tables are not computed for them (NaN blocks, app.reference.multiscatter.load_tables).
_MS_FORMS = ("height_correlated",)


def _accuracy_renderer(ctx: Context, variant: Variant, size: tuple[int, int]) -> Renderer:
    # The GLSL reads the multiple-scattering table's size from the texture.
    scene = load(accuracy_scene(size, variant.model, variant.gbuffer))
    ms_table = None if variant.ms_size is None else load_tables(variant.ms_size, _MS_FORMS)
    return Renderer(ctx.gl, scene, size, RenderOptions(ms_table=ms_table))


def run_accuracy(ctx: Context) -> None:
    """Suite ``accuracy``: each approximation's time and error against its exact form."""
    for comp in comparisons(ctx.settings):
        run_comparison(ctx, comp)
        if comp.name == "gbuffer":
            _run_gbuffer_channels(ctx)
    run_primitives(ctx)
    _run_mip_filtering(ctx)


# (variant, sphere subdivisions or None for the analytic sphere, G-buffer encoding): the
# default, the analytic sphere through the cheaper encodings, and the icospheres (subdivision
# 4 with f16 was the default before the analytic spheres).
PRIMITIVE_VARIANTS = (
    ("analytic f32", None, "f32"),
    ("analytic unorm16_base", None, "unorm16_base"),
    ("analytic unorm16", None, "unorm16"),
    ("analytic f16", None, "f16"),
    ("icosphere 4 f16", 4, "f16"),
    ("icosphere 6 f32", 6, "f32"),
)
PRIMITIVES_TITLE = (
    "spheres and G-buffer encodings against the float64 ray-caster (five spheres, two "
    "directional and two point lights; interior pixels)"
)
SHOWCASE_TITLE = (
    "the default scene (scenes/showcase.toml) as drawn now and with icospheres, against the "
    "float64 ray-caster (interior pixels)"
)


def run_primitives(ctx: Context) -> None:
    """The primitives comparisons: the whole pipeline (sphere geometry and G-buffer encoding)
    against the independent float64 ray-caster of the same scene (app/reference/raycast.py),
    each variant's frames timed interleaved: every variant on the five spheres
    (``primitives``), and the default against the icosphere pipeline on the default
    scene (``primitives_showcase``)."""
    _primitive_case(
        ctx, "primitives", PRIMITIVES_TITLE, PRIMITIVE_VARIANTS,
        lambda sub, gbuffer: five_spheres(sub, gbuffer, point_lights=True),
    )  # fmt: skip
    showcase = scenes_dir() / "showcase.toml"
    _primitive_case(
        ctx, "primitives_showcase", SHOWCASE_TITLE,
        (PRIMITIVE_VARIANTS[0], PRIMITIVE_VARIANTS[4]),
        lambda sub, gbuffer: scene_with_spheres(showcase, sub, gbuffer),
    )  # fmt: skip


def _primitive_case(
    ctx: Context,
    case: str,
    title: str,
    variants: tuple[tuple[str, int | None, str], ...],
    make: Callable[[int | None, str], LoadedScene],
) -> None:
    """One scene's variants against its ray-cast reference. ``rel_rmse`` and the
    statistics are over the ray-caster's interior pixels (2 px from silhouettes);
    ``coverage_mismatch`` over all pixels."""
    size = ctx.settings.accuracy_size
    ctx.progress.start(f"accuracy {case}: float64 ray-caster")
    scenes = {name: make(subdivisions, gbuffer) for name, subdivisions, gbuffer in variants}
    ref = reference_scene(scenes[variants[0][0]], size)
    interior = ref.interior()
    ctx.progress.done()
    ctx.progress.start(f"accuracy {case}: " + ", ".join(v[0] for v in variants))
    renderers = {name: Renderer(ctx.gl, loaded, size) for name, loaded in scenes.items()}
    try:
        times = ctx.time_interleaved({n: deferred_passes(r) for n, r in renderers.items()})
        results = {
            n: (r.read_hdr().astype(np.float64), r.read_gbuffer().covered, len(r.lights))
            for n, r in renderers.items()
        }
        per_pixel = {n: r.gbuffer.layout.bytes_per_pixel() for n, r in renderers.items()}
    finally:
        for r in renderers.values():
            r.release()
    scene = scenes[variants[0][0]].scene
    for name, subdivisions, gbuffer in variants:
        hdr, covered, lights = results[name]
        stats = interior_errors(hdr, ref.hdr, interior, scene.camera.exposure, scene.render.tonemap)
        errors = image_errors(hdr, ref.hdr, interior, 0.0, scene.render.tonemap, flip=False)
        ctx.rows.append(
            make_row(
                "accuracy", case, name, size, lights, times[name],
                default=subdivisions is None and gbuffer == DEFAULT_ENCODING,
                comparison=title, error_reference="float64 ray-caster",
                rel_rmse=errors["rel_rmse"], max_rel_err=stats["max"],
                flip_mean=stats["flip_mean"], rel_median=stats["median"],
                rel_p99=stats["p99"], coverage_mismatch=float(np.mean(covered != ref.covered)),
                bytes_per_pixel=per_pixel[name],
            )
        )  # fmt: skip
    ctx.progress.done()


def run_comparison(ctx: Context, comp: Comparison) -> None:
    """One comparison: its variants timed interleaved, each one's error against the
    float64 twin on the reference variant's G-buffer."""
    s = ctx.settings
    size = s.layered_size if comp.layered else s.accuracy_size
    ctx.progress.start(f"accuracy {comp.name}: float64 reference")
    ref_r = _accuracy_renderer(ctx, comp.reference, size)
    try:
        ref_r.gbuffer_pass.run(ref_r.gbuffer, ref_r.view, ref_r.proj, ref_r.camera)
        g = ref_r.read_gbuffer()
        ms_table = None
        if comp.ms_reference is not None:
            ms_table = load_tables(comp.ms_reference, _MS_FORMS)
        scene = ref_r.scene
        ref = reference_hdr(
            g, ref_r.camera, ref_r.lights, scene.background, ref_r.materials.models,
            ref_r.materials.packed(), None, ms_table,
        )  # fmt: skip
    finally:
        ref_r.release()
    covered = g.covered
    ctx.progress.done()
    ctx.progress.start(f"accuracy {comp.name}: {', '.join(v.name for v in comp.variants)}")
    renderers = {v.name: _accuracy_renderer(ctx, v, size) for v in comp.variants}
    try:
        times = ctx.time_interleaved({n: deferred_passes(r) for n, r in renderers.items()})
        results = {
            n: (r.read_hdr(), bool(np.array_equal(r.read_gbuffer().depth, g.depth)),
                len(r.lights))
            for n, r in renderers.items()
        }  # fmt: skip
        per_pixel = {n: r.gbuffer.layout.bytes_per_pixel() for n, r in renderers.items()}
    finally:
        for r in renderers.values():
            r.release()
    for variant in comp.variants:
        hdr, same_surface, lights = results[variant.name]
        errors = image_errors(hdr, ref, covered, scene.camera.exposure, scene.render.tonemap)
        if comp.name == "gbuffer":  # the encodings' cost in memory too, as allocated
            errors["bytes_per_pixel"] = per_pixel[variant.name]
        ctx.rows.append(
            make_row(
                "accuracy", comp.name, variant.name, size, lights, times[variant.name],
                default=variant.default, comparison=comp.title,
                error_reference=_reference_text(comp), same_depth_as_reference=same_surface,
                **errors,
            )
        )  # fmt: skip
    ctx.progress.done()


def _run_gbuffer_channels(ctx: Context) -> None:
    """The G-buffer encodings' error channel by channel (app/bench/encodings.py), on the
    five default-model spheres and on the varied materials: untimed rows, the error
    against the f32 frame of the same scene (interior pixels, 2 px from silhouettes)."""
    size = ctx.settings.accuracy_size
    for kind in ("spheres", "varied"):
        ctx.progress.start(f"accuracy gbuffer channels: {kind}")
        for row in channel_errors(ctx.gl, encoding_scene(size, kind)):
            ctx.rows.append(
                make_row(
                    "accuracy", f"gbuffer_channels_{kind}",
                    f"{row['channel']}:{row['storage']}", size, 3, None,
                    comparison="one G-buffer channel rounded as the storage would, the "
                    "rest f32", error_reference="the f32 G-buffer's frame (GLSL), interior "
                    "pixels", **{k: v for k, v in row.items() if k.startswith("rel_")},
                )
            )  # fmt: skip
        ctx.progress.done()


def _run_mip_filtering(ctx: Context) -> None:
    """Accuracy comparison ``mip_filtering``: every normal/roughness filtering
    option on scenes/sec13_filtering.toml against the same view rendered with
    ``filtering_supersample``^2 samples per pixel from the unfiltered level 0, with the
    shimmer over a sideways camera sweep (app/bench/filtering.py)."""
    s = ctx.settings
    size = s.filtering_size
    loaded = load_scene(scenes_dir() / "sec13_filtering.toml")
    exposure, tonemap = loaded.scene.camera.exposure, loaded.scene.render.tonemap
    # the scene's own filter is the row marked default (its file names `variance`, which is
    # also what the project's `auto` picks for its isotropic bumps)
    scene_filter = loaded.scene.render.normal_filter
    ref_settings = {"normal_filter": "none", "supersample": s.filtering_supersample}
    ctx.progress.start(f"accuracy mip_filtering: {s.filtering_supersample}^2 reference")
    ref = render_hdr(ctx.gl, with_settings(loaded, size, 0.0, **ref_settings))
    ctx.progress.done()
    covered = np.ones(ref.shape[:2], bool)
    offsets = np.linspace(0.0, SWEEP_METRES, s.filtering_sweep)
    title = (
        f"normal/roughness mip filtering vs a {s.filtering_supersample}x"
        f"{s.filtering_supersample} supersampled reference (scenes/sec13_filtering.toml)"
    )
    ctx.progress.start(f"accuracy mip_filtering: {', '.join(n for n, _ in FILTER_OPTIONS)}")
    renderers = {
        name: Renderer(ctx.gl, with_settings(loaded, size, 0.0, **options))
        for name, options in FILTER_OPTIONS
    }
    try:
        times = ctx.time_interleaved({n: deferred_passes(r) for n, r in renderers.items()})
        first = {n: (r.read_hdr(), len(r.lights)) for n, r in renderers.items()}
    finally:
        for r in renderers.values():
            r.release()
    ctx.progress.done()
    for name, options in FILTER_OPTIONS:
        ctx.progress.start(f"accuracy mip_filtering: {name}, camera sweep")
        frame, lights = first[name]
        frames = [frame] + [
            render_hdr(ctx.gl, with_settings(loaded, size, float(o), **options))
            for o in offsets[1:]
        ]
        errors = image_errors(frames[0], ref, covered, exposure, tonemap)
        ctx.rows.append(
            make_row(
                "accuracy", "mip_filtering", name, size, lights, times[name],
                default=name == scene_filter, comparison=title,
                error_reference=f"{s.filtering_supersample}x{s.filtering_supersample} "
                "samples per pixel from texture level 0, box-filtered",
                shimmer=shimmer(frames, loaded), **errors,
            )
        )  # fmt: skip
        ctx.progress.done()


def _reference_text(comp: Comparison) -> str:
    ref = comp.reference
    text = f"float64 twin, model of variant '{ref.name}', on its {ref.gbuffer} G-buffer"
    if comp.ms_reference is not None:
        text += f", {comp.ms_reference}x{comp.ms_reference} table"
    return text


# --- specialization -------------------------------------------------------------------------

SPECIALIZATION_VARIANTS = ("specialized", "uber")


def specialization_tasks(settings: Settings) -> int:
    return len(SPECIALIZATION_KINDS) * 2  # the variants; the reference


def run_specialization(ctx: Context) -> None:
    """Suite ``specialization``: one lighting program per model group (``specialized``, as
    the renderer ships) against one uber-shader with run-time model selection (``uber``),
    on a Lambert-only (standard model) scene and a mixed-model scene, culled pipeline.

    Both variants draw the same image (tests/test_uber.py); each row records the uber
    image's largest relative difference from the specialized one, and both carry the
    error against the float64 twin on an f32 G-buffer (as the culling suite)."""
    s = ctx.settings
    size, count = s.specialization_size, s.specialization_lights
    light_range = ctx.light_range(count)
    for kind in SPECIALIZATION_KINDS:
        data = specialization_scene(kind, count, light_range, size)
        loaded = load(data)
        pending: list[dict] = []
        ctx.progress.start(f"specialization {kind}: {', '.join(SPECIALIZATION_VARIANTS)}")
        renderers = {
            v: Renderer(ctx.gl, loaded, size, RenderOptions(uber=v == "uber"))
            for v in SPECIALIZATION_VARIANTS
        }
        try:
            times = ctx.time_interleaved({v: deferred_passes(r) for v, r in renderers.items()})
            images = {v: r.read_hdr() for v, r in renderers.items()}
            first = renderers[SPECIALIZATION_VARIANTS[0]]
            pairs = light_pairs(first.read_gbuffer(), first.camera, first.lights)
            programs = {v: len(r.lighting.programs) for v, r in renderers.items()}
            groups = len(first.materials.models)
        finally:
            for r in renderers.values():
                r.release()
        for variant in SPECIALIZATION_VARIANTS:
            pending.append(
                make_row(
                    "specialization", kind, variant, size, count, times[variant],
                    light_range_m=light_range, model_groups=groups,
                    lighting_programs=programs[variant],
                    lights_per_pixel=pairs.mean_per_covered_pixel,
                )
            )  # fmt: skip
        ctx.progress.done()

        ctx.progress.start(f"specialization {kind}: float64 reference and errors")
        ref, covered = f32_reference(ctx.gl, data, pairs)
        cam, render = loaded.scene.camera, loaded.scene.render
        base = images["specialized"][covered].astype(np.float64)
        floor = 1e-3 * float(np.abs(base).max())
        for row in pending:
            image = images[row["variant"]]
            diff = np.abs(image[covered] - base) / np.maximum(np.abs(base), floor)
            row["max_rel_diff_vs_specialized"] = float(diff.max())
            row.update(image_errors(image, ref, covered, cam.exposure, render.tonemap))
            row["error_reference"] = "float64 twin on an f32 G-buffer, in-range pairs"
        ctx.rows.extend(pending)
        ctx.progress.done()


# --- startup --------------------------------------------------------------------------------


def startup_tasks(settings: Settings) -> int:
    return 2 * settings.startup_runs + 1 + len(API_CASES)


PHASES = "step by step"  # the startup row of startup_phases


def run_startup(ctx: Context) -> None:
    """Cold start (process start to PNG written) and peak memory of pbs render, after an
    untimed run that fills the caches; the same start step by step."""
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    s = ctx.settings
    showcase = load_scene(scenes_dir() / "showcase.toml").scene
    size = s.startup_size or (showcase.render.width, showcase.render.height)
    ctx.progress.start("startup: an untimed run (Mesa's shader and Python's bytecode caches)")
    cold_start(s.startup_size, shader_cache=True)
    ctx.progress.done()
    for variant, cache in (("shader cache", True), ("no shader cache", False)):
        runs = []
        for i in range(s.startup_runs):
            ctx.progress.start(f"startup {variant}: run {i + 1}/{s.startup_runs}")
            runs.append(cold_start(s.startup_size, shader_cache=cache))
            ctx.progress.done()
        ok = [r for r in runs if r["to_png_s"] is not None and r["returncode"] == 0]
        if not ok:
            ctx.notes.append(f"startup ({variant}): pbs render failed: {runs[-1]['stderr']}")
            continue
        ms = [r["to_png_s"] * 1e3 for r in ok]
        med, lo, hi = summary(ms)
        ctx.rows.append(
            make_row(
                "startup", "showcase.toml", variant, size, len(showcase.lights), None,
                ms_median=med, ms_min=lo, ms_max=hi, frames=len(ok),
                timer="process spawn to PNG mtime",
                peak_rss_mib=max(r["maxrss_mib"] for r in ok),
                peak_rss_mib_median=statistics.median(r["maxrss_mib"] for r in ok),
                exit_ms_median=statistics.median(r["exit_s"] * 1e3 for r in ok),
                command=ok[0]["command"], runs=runs,
            )
        )  # fmt: skip
    ctx.progress.start(f"startup: the cold start step by step, {s.startup_runs} runs")
    steps = startup_phases(s.startup_size, s.startup_runs)
    ctx.progress.done()
    if "error" in steps:
        ctx.notes.append(f"startup phases: {steps['error']}")
    else:
        ctx.rows.append(
            make_row(
                "startup", "showcase.toml", PHASES, size, len(showcase.lights), None,
                ms_median=statistics.median(steps["totals_s"]) * 1e3,
                ms_min=min(steps["totals_s"]) * 1e3, ms_max=max(steps["totals_s"]) * 1e3,
                frames=steps["runs"],
                timer="stamps in a fresh process doing pbs render's steps (startup_phases.py)",
                phases=steps["phases"], programs_ms=steps["programs_s"] * 1e3,
                programs=steps["programs"],
            )
        )  # fmt: skip
    run_quick_answers(ctx)
    run_api(ctx, size)


def run_quick_answers(ctx: Context) -> None:
    """Rows of the startup suite: ``pbs --help`` and a bad scene refused, whole processes
    from spawn to exit, alternating (app/bench/startup.py ``quick_answers``): three runs
    per cold start's (9 in the full mode, 6 quick)."""
    runs = 3 * ctx.settings.startup_runs
    ctx.progress.start(f"startup: pbs --help and a bad scene refused, {runs} runs each")
    for name, answer in quick_answers(runs).items():
        ms = [r["exit_s"] * 1e3 for r in answer["runs"]]
        med, lo, hi = summary(ms)
        if not answer["ok"]:
            ctx.notes.append(f"startup ({name}): not as expected: {answer['runs'][-1]}")
        ctx.rows.append(
            make_row(
                "startup", answer["command"], name, (0, 0), 0, None,
                ms_median=med, ms_min=lo, ms_max=hi, frames=len(ms),
                timer="process spawn to exit, alternating runs",
                cpu_ms_median=answer["cpu_s_median"] * 1e3, answered_as_expected=answer["ok"],
                runs=answer["runs"],
            )
        )  # fmt: skip
    ctx.progress.done()


# --- the Python API: a renderer's first frame against its next ones ---------------------------

API_CASES = ("showcase.toml", "icosphere 6 mesh (.glb)")
API_NEXT_FRAMES = 5  # camera changes timed after the first frame


def run_api(ctx: Context, size: tuple[int, int]) -> None:
    """The API's frame target, rows of the startup suite: ``OffscreenRenderer`` built and its
    first frame rendered and read (LDR), then ``API_NEXT_FRAMES`` frames each after a camera
    step on an orbit (set_camera, render, read), in one process and one run, for the
    showcase and a helmet-sized mesh. The first frame includes reading the scene and the
    mesh, building and uploading geometry and compiling programs (Mesa's on-disk shader
    cache may hold their machine code); a next frame compiles and uploads nothing
    (tests/test_api.py checks that), so the ratio is what keeping the renderer saves."""
    import tempfile

    from app.api import OffscreenRenderer, scene_from

    with tempfile.TemporaryDirectory(prefix="pbs-bench-api-") as tmp:
        sources = {
            API_CASES[0]: scene_from(scenes_dir() / "showcase.toml"),
            API_CASES[1]: scene_from(api_mesh_scene(Path(tmp)), tmp),
        }
        for case, loaded in sources.items():
            ctx.progress.start(f"startup: API first and next frames, {case}")
            ctx.gl.ctx.finish()
            t0 = time.perf_counter()
            r = OffscreenRenderer(loaded, size, gl=ctx.gl)
            try:
                r.render()
                first_ms = (time.perf_counter() - t0) * 1e3
                programs = len(r.renderer.shaders)
                target = np.array(r.scene.camera.target)
                offset = np.array(r.scene.camera.position) - target
                next_ms = []
                for i in range(1, API_NEXT_FRAMES + 1):
                    angle = 2.0 * np.pi * i / (API_NEXT_FRAMES + 1)
                    c, s_ = np.cos(angle), np.sin(angle)
                    step = [
                        c * offset[0] + s_ * offset[2],
                        offset[1],
                        c * offset[2] - s_ * offset[0],
                    ]
                    t0 = time.perf_counter()
                    r.set_camera(position=(target + step).tolist())
                    r.render()
                    next_ms.append((time.perf_counter() - t0) * 1e3)
                compiled = len(r.renderer.shaders) - programs
                triangles = sum(len(p.indices) // 3 for p in r.renderer.frame.parts)
                lights = len(r.renderer.lights)
            finally:
                r.close()
            med, lo, hi = summary(next_ms)
            timer = "wall clock in process, to the LDR image read back"
            common = {"triangles_drawn": triangles, "timer": timer}
            ctx.rows.append(
                make_row("startup", case, "api first frame", size, lights, None,
                         ms_median=first_ms, ms_min=first_ms, ms_max=first_ms, frames=1,
                         **common)
            )  # fmt: skip
            ctx.rows.append(
                make_row("startup", case, "api next frame after a camera change", size, lights,
                         None, ms_median=med, ms_min=lo, ms_max=hi, frames=len(next_ms),
                         first_over_next=first_ms / med, programs_compiled=compiled, **common)
            )  # fmt: skip
            ctx.progress.done()


def run_viewer(ctx: Context) -> None:
    """Suite ``viewer``: input-to-image latency of the desktop viewer (app/bench/viewer.py)."""
    from app.bench.viewer import IDLE_SECONDS, ORBIT_MOVES, run_child, summary_ms

    size = VIEWER_SIZE
    ctx.progress.start(f"viewer: interactions at {size[0]}x{size[1]}")
    result = run_child(size, ORBIT_MOVES)
    ctx.progress.done()
    if "error" in result:
        ctx.notes.append(f"viewer: not measured: {result['error']}")
        return
    ms = dict(result["ms"])
    idle_cpu, idle_frames = ms.pop("idle cpu percent", None), ms.pop("idle frames", None)
    for interaction, values in ms.items():
        ctx.rows.append(
            make_row("viewer", "showcase.toml", interaction, size, 5, None,
                     frames=len(values), timer="input call to swapped frame (ctx.finish)",
                     **summary_ms(values))
        )  # fmt: skip
    if idle_cpu is not None and idle_frames is not None:
        ctx.rows.append(
            make_row("viewer", "showcase.toml", "idle", size, 5, None,
                     frames=int(idle_frames[0]), cpu_percent=idle_cpu[0],
                     timer=f"process CPU time over {IDLE_SECONDS:g} s of Viewer.run, no input")
        )  # fmt: skip


VIEWER_SIZE = (960, 540)  # the window the latency target is stated for


def run_batch(ctx: Context) -> None:
    """Suite ``batch``: an orbit's images per second, four ways (app/bench/batch.py)."""
    from app.bench.batch import run_batch as run

    run(ctx)


def run_assets(ctx: Context) -> None:
    """Suite ``assets``: a model file, whole process, pbs (cold and warm texture cache)
    against f3d (app/bench/assets.py)."""
    from app.bench.assets import run_assets as run

    run(ctx)


def run_peers(ctx: Context) -> None:
    """Suite ``peers``: pbs against pygfx, PyVista and pyrender on one scene, time and
    error against the ray-cast (app/bench/peers.py)."""
    from app.bench.peers import run_peers as run

    run(ctx)


def run_ibl(ctx: Context) -> None:
    """Suite ``ibl``: the prefilter's (face size, samples) against time, memory and error
    (app/bench/ibl.py)."""
    from app.bench.ibl import run_ibl as run

    run(ctx)


def run_antialiasing(ctx: Context) -> None:
    """Suite ``antialiasing``: each candidate's time against its error to a supersampled
    frame (app/bench/antialiasing.py)."""
    from app.bench.antialiasing import run_antialiasing as run

    run(ctx)


def run_transmission(ctx: Context) -> None:
    """Suite ``transmission``: the screen-space transmission pass's frame time against
    its error to exact refraction through a sphere (app/bench/transmission.py)."""
    from app.bench.transmission import run_transmission as run

    run(ctx)


def run_shadows_and_area_lights(ctx: Context) -> None:
    """Suite ``shadows``: its cases (app/bench/shadows.py), then an area light of each
    shape against a point light on the same scene (app/bench/area_lights.py)."""
    run_shadows(ctx)
    run_area_lights(ctx)


RUNNERS: dict[str, Callable[[Context], None]] = {
    "culling": run_culling,
    "resolution": run_resolution,
    "accuracy": run_accuracy,
    "specialization": run_specialization,
    "startup": run_startup,
    "viewer": run_viewer,
    "batch": run_batch,
    "ibl": run_ibl,
    "shadows": run_shadows_and_area_lights,
    "antialiasing": run_antialiasing,
    "assets": run_assets,
    "peers": run_peers,
    "transmission": run_transmission,
}


def planned_tasks(suites: list[str], settings: Settings, pyrender: bool) -> int:
    """The progress bar's total."""
    counts = {
        "culling": culling_tasks(settings, pyrender),
        "resolution": len(settings.resolutions),
        "accuracy": accuracy_tasks(settings),
        "specialization": specialization_tasks(settings),
        "startup": startup_tasks(settings),
        "viewer": 1,
        "batch": 0,
        "ibl": 0,
        "shadows": shadows_tasks(settings) + 1,  # and the area lights' case
        "antialiasing": 0,
        "assets": 3 * max(1, settings.startup_runs),
        "peers": 0,
        "transmission": 0,
    }
    if "batch" in suites:
        from app.bench.batch import batch_tasks, batch_workers

        counts["batch"] = batch_tasks(pyrender, settings.batch_rounds, batch_workers())
    if "antialiasing" in suites:
        from app.bench.antialiasing import antialiasing_tasks

        counts["antialiasing"] = antialiasing_tasks(settings)
    if "peers" in suites:
        from app.bench.peers import peers_tasks

        counts["peers"] = peers_tasks(settings)
    if "transmission" in suites:
        from app.bench.transmission import transmission_tasks

        counts["transmission"] = transmission_tasks(settings)
    if "ibl" in suites:
        from app.bench.ibl import ibl_tasks

        counts["ibl"] = ibl_tasks(settings)
    return sum(counts[s] for s in suites)
