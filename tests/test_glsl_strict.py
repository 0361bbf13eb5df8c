"""Every GLSL program the project assembles passes Khronos' reference compiler.

Mesa accepts more than GLSL 3.30 allows (a backslash line continuation, which GLSL gained
in 4.20, for one); a stricter driver need not. So the final source text of every stage of
every program the project builds is handed to ``glslangValidator`` (Debian's
``glslang-tools``, installed by scripts/dev.sh), which checks it against the ``#version``
it declares (docs/architecture.md, "Portable GLSL").

The programs are collected where every source reaches the driver: ``moderngl.Context.program``
is wrapped for the collection (the real compile still runs), so the shader cache's, the
kernels' and the viewer's own program are all seen. What is driven: every bundled scene
and every walkthrough step (views, comparisons, each sweep value), every debug view, the
uber shader and the light forms, the bench's passes and variants (culled, unculled, floor,
limit in each light form, forward, accuracy, shadows, antialiasing, filtering, IBL
prefilter), the post pass unfused, the BRDF probe's kernel, and the viewer's present pass.
Identical sources are validated once, in a few batched validator calls run in parallel.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import subprocess
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import moderngl
import pytest

from app.gl.context import GLContext
from app.gl.shaders import ShaderCache, assemble

SIZE = (16, 16)  # every frame's size: the programs do not depend on it
STAGES = {"vertex_shader": "vert", "fragment_shader": "frag", "geometry_shader": "geom",
          "tess_control_shader": "tesc", "tess_evaluation_shader": "tese"}  # fmt: skip


def validator() -> str:
    """The path of glslangValidator. Absent: a skip on a developer's machine, a failure
    in CI (env CI set), where scripts/dev.sh installs it."""
    path = shutil.which("glslangValidator")
    if path is None:
        why = "glslangValidator is not installed (Debian: apt-get install glslang-tools)"
        if os.environ.get("CI"):
            pytest.fail(f"{why}; scripts/dev.sh installs it in CI")
        pytest.skip(why)
    return path


@dataclass
class Sources:
    """Each distinct stage source (keyed by its SHA-256) with its stage and the first
    thing that built it, and how many programs were linked in all."""

    programs: int = 0
    stages: dict[str, tuple[str, str, str]] = field(default_factory=dict)
    origin: str = ""  # what is being driven, named in a rejection's report
    shaders: ShaderCache | None = None  # one cache: a permutation is compiled once

    def add(self, stage: str, text: str) -> None:
        key = hashlib.sha256(text.encode()).hexdigest()[:16] + "." + stage
        self.stages.setdefault(key, (stage, text, self.origin))


@contextlib.contextmanager
def recorded(sources: Sources) -> Iterator[None]:
    """Every program linked in the block adds its stages' source text to ``sources``."""
    compile_program = moderngl.Context.program

    def recording(self: moderngl.Context, **stages: object) -> moderngl.Program:
        sources.programs += 1
        for name, text in stages.items():
            if name in STAGES and isinstance(text, str):
                sources.add(STAGES[name], text)
        return compile_program(self, **stages)

    moderngl.Context.program = recording
    try:
        yield
    finally:
        moderngl.Context.program = compile_program


def validate(
    sources: dict[str, tuple[str, str, str]], folder: Path, workers: int | None = None
) -> dict[str, str]:
    """glslangValidator on each source (written to ``folder`` as KEY.STAGE, the stage
    from the extension): the log of each one it rejects. Sources go to the validator in
    one batch per worker (default: per CPU), run in parallel; the validator compiles each
    file of a batch on its own and prints each one's log after its name."""
    tool = validator()
    names = sorted(sources)
    if not names:
        return {}
    for name in names:
        (folder / name).write_text(sources[name][1], encoding="utf-8")
    workers = max(1, min(len(names), workers or os.cpu_count() or 1))
    batches = [names[i::workers] for i in range(workers)]

    def run(batch: list[str]) -> tuple[int, str, list[str]]:
        done = subprocess.run([tool, *batch], cwd=folder, capture_output=True, text=True)
        return done.returncode, done.stdout + done.stderr, batch

    rejected: dict[str, str] = {}
    with ThreadPoolExecutor(workers) as pool:
        for code, output, batch in pool.map(run, batches):
            logs: dict[str, list[str]] = {}
            current = None
            for line in output.splitlines():
                if line.strip() in batch:
                    current = line.strip()
                    continue
                if current is not None and line.strip():
                    logs.setdefault(current, []).append(line.strip())
            bad = {n: "\n".join(lines) for n, lines in logs.items() if "ERROR" in "".join(lines)}
            if code != 0 and not bad:  # a failure not attributed to a file: all of it
                bad = {batch[0]: output.strip() or f"exit code {code}"}
            rejected.update(bad)
    return rejected


_LOCATION = re.compile(r"ERROR: \d+:(\d+):")


def first_error(text: str, log: str) -> str:
    """The log's first error with the source line it points at: the assembled text
    restarts its numbering at its ``#line 1`` (app/gl/shaders.py), after the header."""
    errors = [line for line in log.splitlines() if line.startswith("ERROR")] or [log]
    match = _LOCATION.match(errors[0])
    if match is None:
        return errors[0]
    body = text.split("\n#line 1\n", 1)[-1].split("\n")
    number = int(match[1])
    quoted = body[number - 1].strip() if 1 <= number <= len(body) else "?"
    return f"{errors[0].strip()} at `{quoted}`"


# --- what is driven -------------------------------------------------------------------------


def _frame(gl: GLContext, sources: Sources, loaded: object, options: object = None) -> None:
    """The renderer of ``loaded`` built (with the collection's shader cache), its plain
    frame's fused display programs too, and released."""
    from app.render.renderer import Renderer, RenderOptions

    renderer = Renderer(gl, loaded, SIZE, options or RenderOptions(), sources.shaders)
    try:
        _display_programs(renderer)
    finally:
        renderer.release()


def _display_programs(renderer: object) -> None:
    """Building a renderer links every program its frames draw with (app/render/renderer.py
    ``SCHEDULE``) but a plain frame's lighting pass that writes the display image, which is
    compiled at its first draw: built here without drawing (a draw would add llvmpipe's JIT
    of each shader, most of the collection's time)."""
    if renderer.fused_display and renderer.lighting is not None:
        # "gbaa" frames also write the surfaces' radiance (HDR_OUT)
        hdr_out = getattr(renderer, "gbaa", None) is not None
        renderer.lighting.display_draws(renderer.scene.render.tonemap, hdr_out)


def _bundled_scenes(gl: GLContext, sources: Sources) -> None:
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    for path in sorted(scenes_dir().glob("*.toml")):
        sources.origin = f"scene {path.name}"
        _frame(gl, sources, load_scene(path))


def _walkthrough(gl: GLContext, sources: Sources) -> None:
    from app.render.compare import CompareSpec
    from app.render.renderer import Renderer
    from app.resources import walkthrough_dir
    from app.walkthrough.model import load_walkthrough, with_values

    for step in load_walkthrough(walkthrough_dir()):
        for ref, loaded in step.scenes.items():
            sources.origin = f"walkthrough {step.slug} scene {ref}"
            _frame(gl, sources, loaded)
        for i, item in enumerate(step.step.comparisons):
            sources.origin = f"walkthrough {step.slug} comparisons[{i}]"
            spec = CompareSpec(item.key, item.a, item.b, origin=sources.origin)
            for side in spec.scenes(step.scene(item.scene), SIZE):
                _frame(gl, sources, side)
        for i, sweep in enumerate(step.step.sweeps):
            sources.origin = f"walkthrough {step.slug} sweeps[{i}]"
            where = f"sweeps[{i}]"
            renderer = None
            try:
                for value in sweep.values():
                    scene = with_values(step.scene(sweep.scene), sweep.keys, value, step.path,
                                        where, where)  # fmt: skip
                    if renderer is None:
                        renderer = Renderer(gl, scene, SIZE, shaders=sources.shaders)
                    else:
                        renderer.update(scene.scene)
                    _display_programs(renderer)
            finally:
                if renderer is not None:
                    renderer.release()


def _compare_composites(gl: GLContext, sources: Sources) -> None:
    from app.render.compare import MODES, CompareSpec, Comparison
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    sources.origin = "pbs compare composites"
    spec = CompareSpec("lights[0].intensity", 1.0, 2.0, origin=sources.origin)
    comparison = Comparison(gl, load_scene(scenes_dir() / "sec1_both.toml"), spec, SIZE)
    try:
        comparison.render()
        for mode in MODES:
            comparison.composite(mode)
    finally:
        comparison.release()


def _debug_views(gl: GLContext, sources: Sources) -> None:
    from app.common.debug_views import DEBUG_VIEWS
    from app.render.debug_views import DebugPass
    from app.render.renderer import Renderer
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    # showcase: one model group; sec7_g2_backlit: several (one program per group)
    for name in ("showcase", "sec7_g2_backlit"):
        sources.origin = f"debug views of {name}"
        loaded = load_scene(scenes_dir() / f"{name}.toml")
        renderer = Renderer(gl, loaded, SIZE, shaders=sources.shaders)
        debug = None
        try:
            renderer.render()
            debug = DebugPass(renderer)
            for view in DEBUG_VIEWS:
                debug.run(view)
        finally:
            if debug is not None:
                debug.release()
            renderer.release()


def _pipeline_options(gl: GLContext, sources: Sources) -> None:
    from app.bench.scenes import SPECIALIZATION_KINDS, load, specialization_scene
    from app.render.lighting import LIGHT_FORMS
    from app.render.renderer import RenderOptions
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    for kind in SPECIALIZATION_KINDS:
        loaded = load(specialization_scene(kind, 16, 2.0, SIZE))
        sources.origin = f"specialization {kind}"
        _frame(gl, sources, loaded)
    # the uber shader: one lighting program whatever the materials
    sources.origin = "specialization mixed, uber shader"
    _frame(gl, sources, loaded, RenderOptions(uber=True))
    showcase = load_scene(scenes_dir() / "showcase.toml")
    for form in LIGHT_FORMS:
        sources.origin = f"showcase light_form={form}"
        _frame(gl, sources, showcase, RenderOptions(light_form=form))
    sources.origin = "showcase unfused post, RT0/RT1 surfaces kept"
    _frame(gl, sources, showcase, RenderOptions(fuse_post=False, constant_surfaces=False))


def _bench_culling(gl: GLContext, sources: Sources) -> None:
    from app.bench.floor import FloorPass
    from app.bench.forward import ForwardRenderer
    from app.bench.limit import FORMS, LimitPass
    from app.bench.pairs import light_pairs
    from app.bench.scenes import load, many_lights_scene
    from app.render.renderer import Renderer

    for count in (1, 16):
        data = many_lights_scene(count, 2.0, SIZE)
        for culling in ("tiled", "none", "auto"):
            sources.origin = f"bench culling {count} lights light_culling={culling}"
            render = {**data["render"], "light_culling": culling}
            _frame(gl, sources, load({**data, "render": render}))
        sources.origin = f"bench floor, limit, forward at {count} lights"
        loaded = load(data)
        culled = Renderer(gl, loaded, SIZE, shaders=sources.shaders)
        passes: list = []
        try:
            culled.gbuffer_pass.run(culled.gbuffer, culled.view, culled.proj, culled.camera)
            pairs = light_pairs(culled.read_gbuffer(), culled.camera, culled.lights)
            passes = [FloorPass(culled, pairs), *(LimitPass(culled, pairs, f) for f in FORMS)]
            for p in passes:
                p.run()
            forward = ForwardRenderer(gl, loaded, SIZE)
            passes.append(forward)
            forward.render()
        finally:
            for p in passes:
                p.release()
            culled.release()


def _bench_variants(gl: GLContext, sources: Sources) -> None:
    from app.bench.antialiasing import CANDIDATES, aa_scene_data, with_aa
    from app.bench.context import FULL
    from app.bench.filtering import OPTIONS, with_settings
    from app.bench.scenes import accuracy_scene, load
    from app.bench.shadows import FILTERS, LIGHTS, shadow_scene, with_shadow
    from app.bench.shadows import _load as shadow_load
    from app.bench.suites import comparisons, layered_comparisons
    from app.reference.multiscatter import load_tables
    from app.render.renderer import RenderOptions
    from app.resources import scenes_dir
    from app.scene.loader import load_scene
    from app.scene.sources import scene_from

    seen: set[tuple] = set()
    for comp in [*comparisons(FULL), *layered_comparisons()]:
        for variant in (*comp.variants, comp.reference):
            key = (repr(variant.model), variant.gbuffer, variant.ms_size)
            if key in seen:
                continue
            seen.add(key)
            sources.origin = f"bench accuracy {comp.name} {variant.name}"
            ms = (
                None
                if variant.ms_size is None
                else load_tables(variant.ms_size, ("height_correlated",))
            )
            scene = load(accuracy_scene(SIZE, variant.model, variant.gbuffer))
            _frame(gl, sources, scene, RenderOptions(ms_table=ms))
    for kind, light in LIGHTS.items():
        for shadow_filter in FILTERS:
            sources.origin = f"bench shadows {kind} {shadow_filter}"
            lit = with_shadow(light, kind, shadow_filter, 64)
            _frame(gl, sources, shadow_load(shadow_scene(lit, SIZE)))
    aa = scene_from(aa_scene_data(SIZE))
    for name, mode, n, specular_aa in CANDIDATES:
        sources.origin = f"bench antialiasing {name}"
        _frame(gl, sources, with_aa(aa, mode, n, 1, specular_aa))
    sources.origin = "bench antialiasing supersampled reference"
    _frame(gl, sources, with_aa(aa, "none", 1, 2))
    filtering = load_scene(scenes_dir() / "sec13_filtering.toml")
    for name, render in OPTIONS:
        sources.origin = f"bench filtering {name}"
        _frame(gl, sources, with_settings(filtering, SIZE, **render))


def _ibl_prefilter(gl: GLContext, sources: Sources) -> None:
    import numpy as np

    from app.bench.ibl import prefilter_ms

    sources.origin = "bench ibl prefilter"
    env = np.ones((8, 16, 3), np.float32)
    prefilter_ms(gl, env, 16, 1)


def _brdf_probe(gl: GLContext, sources: Sources) -> None:
    """The BRDF probe's kernel (``pbs brdf``, the walkthrough's plots) for each model the
    walkthrough plots: its source depends on the material's model alone."""
    from app.brdf import evaluate
    from app.brdf.plot import parse_material_args
    from app.resources import walkthrough_dir
    from app.walkthrough.model import load_walkthrough

    seen = set()
    for step in load_walkthrough(walkthrough_dir()):
        for plot in step.step.plots:
            for material in parse_material_args(plot.materials):
                if material.params.model in seen:
                    continue
                seen.add(material.params.model)
                sources.origin = f"BRDF probe kernel, {step.slug} plot {material.name}"
                evaluate(material.params, [0.0, 0.0, 1.0], [0.0, 0.6, 0.8], gl=gl)


def _viewer_present(gl: GLContext, sources: Sources) -> None:
    from app.viewer.window import _Present

    sources.origin = "viewer present pass"
    _Present(gl.ctx).release()


def _normal_mapped_shadows_and_coat_film_maps(gl: GLContext, sources: Sources) -> None:
    """What no bundled scene has: a shadowed normal-mapped receiver (SHADOW_FACE_NORMAL,
    tests/test_shadow_offset.py) and glTF clear-coat roughness and iridescence textures
    (G-buffer RT8), opaque and alpha-blended (the forward pass)."""
    import tempfile

    from app.scene.loader import load_scene, parse_scene
    from tests.gltf_builder import GltfBuilder
    from tests.test_gltf_extension_maps import NEAREST, QUAD_SCENE, dielectric, halves
    from tests.test_shadow_offset import _scene

    with tempfile.TemporaryDirectory() as folder:
        here = Path(folder)
        sources.origin = "a shadowed normal-mapped quad"
        _frame(gl, sources, parse_scene(_scene(here, shadow=True), here / "t.toml"))
        for mode in ("OPAQUE", "BLEND"):
            b = GltfBuilder()
            tex = {"index": b.texture(halves((0, 0, 0), (255, 255, 0)), NEAREST)}
            ext = {
                "KHR_materials_clearcoat": {"clearcoatFactor": 1.0,
                                            "clearcoatRoughnessTexture": tex},
                "KHR_materials_iridescence": {"iridescenceFactor": 1.0,
                                              "iridescenceTexture": tex,
                                              "iridescenceThicknessTexture": tex},
            }  # fmt: skip
            material = dielectric(ext)
            material.alphaMode = mode
            b.quad(b.material(material))
            b.doc.extensionsUsed = sorted(ext)
            b.save(here / "m.glb")
            (here / "scene.toml").write_text(QUAD_SCENE, encoding="utf-8")
            sources.origin = f"a glTF quad with RT8's maps, {mode}"
            _frame(gl, sources, load_scene(here / "scene.toml"))


DRIVERS: tuple[Callable[[GLContext, Sources], None], ...] = (
    _bundled_scenes,
    _normal_mapped_shadows_and_coat_film_maps,
    _walkthrough,
    _compare_composites,
    _debug_views,
    _pipeline_options,
    _bench_culling,
    _bench_variants,
    _ibl_prefilter,
    _brdf_probe,
    _viewer_present,
)


def collect(
    gl: GLContext, each: Callable[[dict[str, tuple[str, str, str]]], None] | None = None
) -> Sources:
    """The source of every stage of every program the drivers above link; ``each`` is
    handed the sources new after each driver (the test validates them meanwhile)."""
    sources = Sources(shaders=ShaderCache(gl.ctx))
    try:
        with recorded(sources):
            for drive in DRIVERS:
                before = set(sources.stages)
                drive(gl, sources)
                if each is not None:
                    each({k: v for k, v in sources.stages.items() if k not in before})
    finally:
        sources.shaders.release()
    return sources


# --- the tests ------------------------------------------------------------------------------


def test_every_assembled_program_passes_glslang(gl_egl, tmp_path):
    """glslangValidator accepts every stage of every program the project links. Each
    driver's new sources are validated on another thread while the next driver compiles."""
    validator()
    with ThreadPoolExecutor(1) as pool:
        pending = []
        sources = collect(
            gl_egl, lambda new: pending.append(pool.submit(validate, new, tmp_path, 1))
        )
        rejected = {k: v for future in pending for k, v in future.result().items()}
    assert sources.programs > 100 and len(sources.stages) > 100, sources.programs
    report = [
        f"{name} ({sources.stages[name][2]}): {first_error(sources.stages[name][1], log)}"
        for name, log in sorted(rejected.items())
    ]
    assert not rejected, (
        f"{len(rejected)} of {len(sources.stages)} distinct sources "
        f"({sources.programs} programs) rejected:\n" + "\n".join(report[:20])
    )


def test_a_planted_line_continuation_is_rejected(tmp_path):
    """The checker itself can fail: a program with a backslash continuation in a
    #define (GLSL 4.20 and later only) is rejected, the same program without it passes."""
    clean = assemble("passes/post.frag", {"TONEMAP": 0})
    planted = clean.replace("#line 1\n", "#line 1\n#define X 1 \\\n + 1\n", 1)
    assert planted != clean
    stages = {"clean.frag": ("frag", clean, "clean"), "planted.frag": ("frag", planted, "planted")}
    rejected = validate(stages, tmp_path, workers=1)  # one batch: each file's own log
    assert set(rejected) == {"planted.frag"}, rejected
    error = first_error(planted, rejected["planted.frag"])
    assert "line continuation" in error and "at `#define X 1 \\`" in error, error
