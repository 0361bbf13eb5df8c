"""What ``pbs`` imports before it answers: the parser alone for ``--help`` and a bad
option, the scene layer alone for a bad scene, GL and the renderer only for a render.

Structural, not timed (the wall-clock targets are rows of ``pbs bench --suites startup``,
docs/performance.md "Start-up"): each case runs ``app.cli.main`` in a fresh interpreter
and lists the modules it left in ``sys.modules``, and a module that the command did not
need is a failure however fast the machine is.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

# Run app.cli.main(argv) in this interpreter, then print its exit code, its stderr and
# every module imported by then.
PROBE = """
import contextlib, io, json, sys
from app.cli import main
err = io.StringIO()
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
    code = main(sys.argv[1:])
print(json.dumps({"code": code, "stderr": err.getvalue(), "modules": sorted(sys.modules)}))
"""

# The GL stack and everything above the scene layer: a render needs them, nothing else does.
GL_STACK = (
    "moderngl", "glcontext", "OpenGL", "glfw", "imgui_bundle", "matplotlib",
    "app.gl", "app.frame", "app.render", "app.api", "app.brdf", "app.batch",
    "app.walkthrough", "app.viewer", "app.bench",
)  # fmt: skip
# What the parser alone must not import either: the array, image, mesh and validation
# libraries and the modules built on them.
PARSER_HEAVY = (
    *GL_STACK, "numpy", "pydantic", "PIL", "trimesh", "scipy",
    "app.output", "app.reference", "app.textures", "app.scene.model", "app.scene.loader",
)  # fmt: skip
# The image library and the texture layer: a scene's maps are read only once it is valid
# (a still render's switches, app.textures.decoded and app.scene.early_images, are
# standard library alone).
IMAGE_LAYER = (
    "PIL", "app.textures.maps", "app.textures.cache", "app.textures.mips",
    "app.textures.lean", "app.textures.early",
)  # fmt: skip


def run_cli(
    *argv: str, cwd: Path = REPO, probe: str | None = None, env: dict | None = None
) -> dict:
    """``pbs ARGV`` in a fresh interpreter under ``probe`` (``PROBE`` by default) with
    ``env`` (this one's, the checkout on PYTHONPATH, by default): {"code", "stderr",
    "modules"} and whatever else the probe reports."""
    env = env if env is not None else {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", probe or PROBE, *argv],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def among(modules: list[str], names: tuple[str, ...]) -> list[str]:
    """The ``modules`` that are one of ``names`` or inside one of them."""
    return [m for m in modules if any(m == n or m.startswith(n + ".") for n in names)]


@pytest.mark.parametrize(
    "argv",
    [
        ("--help",),
        ("render", "--help"),
        ("view", "--help"),
        ("brdf", "--help"),
        ("batch", "--help"),
        ("walkthrough", "--help"),
        ("textures", "--help"),
    ],
    ids=lambda argv: " ".join(argv),
)
def test_help_imports_the_parser_alone(argv: tuple[str, ...]) -> None:
    result = run_cli(*argv)
    assert result["code"] == 0
    assert among(result["modules"], PARSER_HEAVY) == []


def test_a_bad_option_is_refused_by_the_parser_alone(tmp_path: Path) -> None:
    result = run_cli("render", "scene.toml", "-o", str(tmp_path / "x.png"), "--debug", "nope")
    assert result["code"] == 2
    assert "--debug" in result["stderr"]
    assert among(result["modules"], PARSER_HEAVY) == []


BAD_SCENES = {
    "unknown key": ("[camera]\ncolour = 3\n", "camera.colour"),
    "bad value": ('[render]\nwidth = "wide"\n', "render.width"),
    "malformed TOML": ("not [ toml\n", "malformed TOML"),
    "bad material": ("[materials.m]\nroughness = 2.0\n", "materials.m.roughness"),
}


@pytest.mark.parametrize("case", BAD_SCENES)
def test_a_bad_scene_is_refused_without_the_gl_stack(tmp_path: Path, case: str) -> None:
    text, named = BAD_SCENES[case]
    scene = tmp_path / "bad.toml"
    scene.write_text(text, encoding="utf-8")
    out = tmp_path / "x.png"
    result = run_cli("render", str(scene), "-o", str(out))
    assert result["code"] == 2
    assert named in result["stderr"] and len(result["stderr"].splitlines()) == 1
    assert not out.exists()
    assert among(result["modules"], GL_STACK) == []
    assert among(result["modules"], IMAGE_LAYER) == []


def test_a_bad_job_file_is_refused_without_the_gl_stack(tmp_path: Path) -> None:
    jobs = tmp_path / "jobs.toml"
    jobs.write_text('scene = "showcase"\n[orbit]\nframes = "many"\n', encoding="utf-8")
    result = run_cli("batch", str(jobs), "-o", str(tmp_path / "out"))
    assert result["code"] == 2
    assert "orbit.frames" in result["stderr"], result["stderr"]
    # app.batch.jobs reads the job file; its workers (app.batch.run, .worker, .pool) hold GL.
    heavy = (*(n for n in GL_STACK if n != "app.batch"), "app.batch.run", "app.batch.worker")
    assert among(result["modules"], heavy) == []


@pytest.mark.gl
def test_a_render_imports_the_gl_stack(tmp_path: Path) -> None:
    """The probe sees what a command imports: a render that succeeds lists GL and the
    renderer (else the tests above could pass on a probe that lists nothing)."""
    out = tmp_path / "x.png"
    result = run_cli("render", "sec3_lambert", "-o", str(out), "--size", "16x9", "-q")
    assert result["code"] == 0, result["stderr"]
    assert out.is_file()
    assert {"moderngl", "app.render.renderer", "app.gl.context"} <= set(result["modules"])


@pytest.mark.gl
def test_a_render_of_primitives_imports_no_mesh_reader(tmp_path: Path) -> None:
    """The showcase (a plane and analytic spheres, shadowed: the shadow pass takes each
    sphere's icosphere; no mesh file; the studio environment) is built without trimesh and
    its scipy (app/scene/icosphere.py gives trimesh's icosphere without importing it), the
    glTF reader and the model-file defaults; the same scene without its environment
    imports the environment's decoder and twins neither."""
    out = tmp_path / "x.png"
    result = run_cli("render", "showcase", "-o", str(out), "--size", "32x18", "-q")
    assert result["code"] == 0, result["stderr"]
    assert out.is_file()
    unused = ("trimesh", "scipy", "app.scene.gltf", "app.scene.gltf_schema",
              "app.scene.model_file")  # fmt: skip
    assert among(result["modules"], unused) == []
    environment = ("app.textures.environment", "app.reference.ibl")
    assert set(environment) <= set(result["modules"])  # the probe sees them where used
    text = (REPO / "scenes" / "showcase.toml").read_text(encoding="utf-8")
    table = text[text.index("[environment]") : text.index("[render]")]
    scene = tmp_path / "no_environment.toml"
    scene.write_text(text.replace(table, ""), encoding="utf-8")
    result = run_cli("render", str(scene), "-o", str(out), "--size", "32x18", "-q")
    assert result["code"] == 0, result["stderr"]
    assert among(result["modules"], (*unused, *environment)) == []


def test_the_bench_times_both_quick_answers() -> None:
    """``pbs bench --suites startup``'s rows: both answers given as they should be (help
    exit 0; the bad scene exit 2, one line naming the misspelt key, no PNG), and a
    verdict for each target. The times are recorded, never asserted."""
    from app.bench.context import make_row
    from app.bench.report import evaluate_targets
    from app.bench.startup import BAD_SCENE, HELP, quick_answers

    answers = quick_answers(runs=1)
    assert set(answers) == {HELP, BAD_SCENE}
    assert all(answer["ok"] for answer in answers.values()), answers
    rows = [
        make_row(
            "startup", a["command"], name, (0, 0), 0, None, ms_median=a["exit_s_median"] * 1e3,
            ms_min=0.0, ms_max=0.0, frames=1, cpu_ms_median=a["cpu_s_median"] * 1e3,
            answered_as_expected=a["ok"],
        )
        for name, a in answers.items()
    ]  # fmt: skip
    verdicts = [v for v in evaluate_targets(rows) if "spawn to exit" in v.target]
    assert len(verdicts) == 2
    assert all(v.status in ("PASS", "FAIL") for v in verdicts)


@pytest.mark.parametrize(
    ("help_s", "bad_s", "as_expected", "statuses"),
    [
        (0.25, 0.45, True, ["PASS", "PASS"]),
        (0.35, 0.55, True, ["FAIL", "FAIL"]),
        (0.25, 0.45, False, ["FAIL", "FAIL"]),  # fast, but not the right answer
    ],
)
def test_the_quick_answer_targets(
    help_s: float, bad_s: float, as_expected: bool, statuses: list[str]
) -> None:
    """``pbs --help`` <= 0.3 s and a bad scene refused <= 0.5 s, on the rows' medians."""
    from app.bench.context import make_row
    from app.bench.report import evaluate_targets
    from app.bench.startup import BAD_SCENE, HELP

    rows = [
        make_row(
            "startup", name, name, (0, 0), 0, None, ms_median=s * 1e3, ms_min=s * 900,
            ms_max=s * 1100, frames=9, cpu_ms_median=s * 500, answered_as_expected=as_expected,
        )
        for name, s in ((HELP, help_s), (BAD_SCENE, bad_s))
    ]  # fmt: skip
    verdicts = [v for v in evaluate_targets(rows) if "spawn to exit" in v.target]
    assert [v.status for v in verdicts] == statuses
    assert f"{help_s:.2f} s median of 9" in verdicts[0].measured


# The probe, watching the first import of numpy: OPENBLAS_NUM_THREADS as it stood then.
BLAS_PROBE = PROBE.replace(
    "from app.cli import main",
    """import os
class _Watch:
    seen = None
    def find_spec(self, name, path=None, target=None):
        if name == "numpy" and _Watch.seen is None:
            _Watch.seen = os.environ.get("OPENBLAS_NUM_THREADS", "")
sys.meta_path.insert(0, _Watch())
from app.cli import main""",
).replace('"code": code,', '"code": code, "blas": _Watch.seen,')


@pytest.mark.parametrize("given", [None, "3"])
@pytest.mark.parametrize("command", ["batch", "view"])
def test_batch_and_view_ask_openblas_for_one_thread(
    tmp_path: Path, command: str, given: str | None
) -> None:
    """``pbs batch`` (and so its worker processes, which inherit the environment) and
    ``pbs view`` set ``OPENBLAS_NUM_THREADS`` to 1 before numpy is imported, as a render
    does (docs/performance.md), a value the environment gives kept. Each is given a job
    file or scene it refuses (exit 2) once numpy is loaded: no GL, no window."""
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(
        'scene = "sec5_metals"\nsweep = { key = "materials.nope.roughness", values = [0.1] }\n',
        encoding="utf-8",
    )
    argv = {
        "batch": ["batch", str(jobs), "-o", str(tmp_path / "out")],
        "view": ["view", str(tmp_path / "missing.toml")],
    }[command]
    result = _probed(BLAS_PROBE, argv, given)
    assert result["code"] == 2, result["stderr"]
    assert result["blas"] == (given or "1")


def _probed(probe: str, argv: list[str], given: str | None) -> dict:
    """The probe's report of ``pbs ARGV`` run in a child with ``OPENBLAS_NUM_THREADS``
    unset, or set to ``given``."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop("OPENBLAS_NUM_THREADS", None)
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    return run_cli(*argv, probe=probe, env=env)


@pytest.mark.gl
@pytest.mark.parametrize("given", [None, "3"])
def test_a_render_asks_openblas_for_one_thread(tmp_path: Path, given: str | None) -> None:
    """A render sets ``OPENBLAS_NUM_THREADS`` to 1 before numpy is imported (OpenBLAS's
    threads spin after each product: docs/performance.md), unless the environment gives
    a value, which is kept."""
    probe = PROBE.replace(
        '"code": code,',
        '"code": code, "blas": __import__("os").environ.get("OPENBLAS_NUM_THREADS"),',
    )
    argv = ["render", "sec3_lambert", "-o", str(tmp_path / "x.png"), "--size", "16x9", "-q"]
    result = _probed(probe, argv, given)
    assert result["code"] == 0, result["stderr"]
    assert result["blas"] == (given or "1")


# A render whose prepared-texture entries take long to write: each write on the cache's
# writer thread waits first, so a process that ended without waiting for them would lose
# them. ``main()`` reads the process's own command line (and ends the process after a
# render); ``main(argv)`` returns, and the interpreter's usual exit follows.
SLOW_WRITES = """
import sys, time
import app.textures.cache as cache
write = cache.PreparedCache._write_now
def slow(self, key, arrays):
    time.sleep(0.3)
    write(self, key, arrays)
cache.PreparedCache._write_now = slow
from app.cli import main
if sys.argv[1] == "own":
    sys.argv = ["pbs", *sys.argv[2:]]
    raise SystemExit(main())
raise SystemExit(main(sys.argv[2:]))
"""


@pytest.mark.gl
def test_a_render_process_ends_once_its_entries_are_written(tmp_path: Path) -> None:
    """``pbs render`` ends its own process after the PNG (app.cli ``_end_process``: no
    Python teardown), but only once the texture layer's background work has ended: the
    same prepared-texture entries on disk as after the interpreter's usual exit, no
    temporary file left, and what it printed flushed."""
    model = REPO / "scenes" / "meshes" / "material_sampler.glb"
    written = {}
    for how in ("own", "returned"):
        out, cache_dir = tmp_path / f"{how}.png", tmp_path / how
        env = {**os.environ, "PYTHONPATH": str(REPO), "PBS_CACHE_DIR": str(cache_dir)}
        env.pop("PBS_CACHE", None)
        argv = ["render", str(model), "-o", str(out), "--size", "32x32"]
        proc = subprocess.run(
            [sys.executable, "-c", SLOW_WRITES, how, *argv],
            cwd=REPO, env=env, capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith(f"{out}: 32x32"), proc.stdout
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        written[how] = sorted(p.name for p in cache_dir.rglob("*") if p.is_file())
    assert len(written["returned"]) >= 2, written  # the model's maps have entries
    assert written["own"] == written["returned"]


@pytest.mark.gl
def test_a_still_gltf_render_imports_no_numpy_ma(tmp_path: Path) -> None:
    """The still's level bound frames the points its faces use without ``np.unique``,
    whose first call imports numpy.ma (10 ms of a render's start: docs/performance.md,
    "A real asset against f3d"); nothing else of a model render needs it."""
    model = REPO / "tests" / "assets" / "BoxTextured.glb"  # textured: a bound is taken
    out = tmp_path / "x.png"
    result = run_cli("render", str(model), "-o", str(out), "--size", "32x32", "-q")
    assert result["code"] == 0, result["stderr"]
    assert out.is_file()
    assert "app.scene.sampled_levels" in result["modules"]  # the bound was taken
    assert among(result["modules"], ("numpy.ma",)) == []


# ``main()`` on the process's own command line (``own``) or on a given one; then whether
# Python's cyclic collector is on, and the exit code.
COLLECTOR = """
import gc, sys
from app.cli import main
if sys.argv[1] == "own":
    sys.argv = ["pbs", *sys.argv[2:]]
    code = main()
else:
    code = main(sys.argv[2:])
print(gc.isenabled(), code)
"""


@pytest.mark.parametrize(
    ("how", "command", "enabled"),
    [("own", "render", False), ("given", "render", True), ("own", "batch", True)],
)
def test_only_a_render_process_switches_the_cycle_collector_off(
    tmp_path: Path, how: str, command: str, enabled: bool
) -> None:
    """A ``pbs render`` process draws one image and ends, so it runs without the cyclic
    collector (app.cli ``_no_cycle_collection``); a render called with its arguments (a
    test, a caller's process) and the other commands keep it. The scene is refused
    (exit 2): the switch is made before the scene is read, and a refused render returns
    instead of ending its process."""
    argv = [command, str(tmp_path / "missing.toml")]
    argv += ["-o", str(tmp_path / ("x.png" if command == "render" else "out"))]
    proc = subprocess.run(
        [sys.executable, "-c", COLLECTOR, how, *argv],
        cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)},
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == [str(enabled), "2"], (proc.stdout, proc.stderr)


@pytest.mark.parametrize("own", [True, False])
def test_the_cli_process_looks_for_no_pydantic_plugins(tmp_path: Path, own: bool) -> None:
    """In its own process (``main()``) the command builds the scene's models with
    pydantic's plugins off and unsearched (app.cli ``_no_pydantic_plugins``): no
    ``importlib.metadata`` (52 modules) and no scan of the installed distributions before
    a bad scene is refused, and pydantic's loader module still answers for the names it
    has. Called with its arguments (a caller's process) it leaves pydantic as it is."""
    scene = tmp_path / "bad.toml"
    scene.write_text(BAD_SCENES["bad material"][0], encoding="utf-8")
    probe = PROBE.replace(
        '"modules": sorted(sys.modules)',
        '"modules": sorted(sys.modules), "group": __import__('
        '"pydantic.plugin._loader", fromlist=["x"]).PYDANTIC_ENTRY_POINT_GROUP',
    )
    if own:  # main() on the process's own command line (a refused render returns)
        probe = probe.replace("code = main(sys.argv[1:])", "sys.argv[0] = 'pbs'; code = main()")
    result = run_cli("render", str(scene), "-o", str(tmp_path / "x.png"), probe=probe)
    assert result["code"] == 2
    assert "pydantic" in result["modules"]  # the models were built
    searched = among(result["modules"], ("importlib.metadata",)) != []
    assert searched is not own
    assert result["group"] == "pydantic"
