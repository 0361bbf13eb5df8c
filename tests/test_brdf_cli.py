"""``pbs brdf``: BRDF Explorer-style plots (app/brdf/plot.py, docs/brdf-explorer.md).

Three real ``python -m app brdf`` runs (one preset; two materials side by side; a scene
file) check the PNG's size and that it holds a plot; bad input is checked in-process
(``app.cli.main`` fails before any GL or matplotlib work) plus once end to end; and the
numbers behind the albedo panel are checked against closed forms: a white Lambert lobe
integrates to exactly 1, a smooth dielectric's specular follows its Fresnel reflectance,
and the GGX lobe at alpha = 1 has the albedo 1 - ln 2 head-on.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.brdf import evaluate
from app.brdf.plot import (
    ALBEDO_THETAS,
    NamedMaterial,
    albedo_curve,
    incident,
    lobes,
    outgoing,
    parse_material_arg,
)
from app.cli import main
from app.gl.context import GLContext
from app.reference.constants import MIN_N_DOT_V
from app.reference.fresnel import F_schlick

REPO = Path(__file__).resolve().parent.parent
INLINE = "{ roughness = 0.2, base_color = [0.7, 0.1, 0.1] }"
SCENE = """\
[materials.chrome]
preset = "chromium"
roughness = 0.25

[materials.clay]
base_color = [0.6, 0.35, 0.2]
roughness = 0.9
"""


def _app(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, "-m", "app", "brdf", *argv],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip


def _pixels(path: Path, size: tuple[int, int]) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == size
        return np.asarray(image.convert("RGB"), np.float64)


# -- the command, end to end -----------------------------------------------------------------

# A blank (single-colour) image has std 0; these plots measure 35-45 (white background,
# dark text and curves), so 15 tells a plot from an empty or nearly empty canvas.
MIN_STD = 15.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    """Each plot rendered once: name -> (PNG, stdout)."""
    out = tmp_path_factory.mktemp("brdf")
    (out / "scene.toml").write_text(SCENE, encoding="utf-8")
    jobs = {
        "preset": ("gold", "-o", "one.png", "--size", "360x520"),
        "pair": ("gold", INLINE, "-o", "pair.png", "--size", "720x520", "--log", "--rgb"),
        "scene": ("scene.toml", "-o", "sub/scene.png", "--size", "720x520", "--quantity", "f"),
    }
    result = {}
    for name, argv in jobs.items():
        proc = _app(*argv, cwd=out)
        assert proc.returncode == 0, f"{name}: exit {proc.returncode}\n{proc.stderr}"
        result[name] = (out / argv[argv.index("-o") + 1], proc.stdout)
    return result


@pytest.mark.gl
def test_one_preset(runs: dict[str, tuple[Path, str]]) -> None:
    png, stdout = runs["preset"]
    assert _pixels(png, (360, 520)).std() > MIN_STD
    assert stdout.startswith("one.png: 360x520, 1 material(s), glsl backend")
    assert [p.name for p in png.parent.iterdir() if p.name.startswith(".")] == []  # no temp


@pytest.mark.gl
def test_two_materials_side_by_side(runs: dict[str, tuple[Path, str]]) -> None:
    png, stdout = runs["pair"]
    pixels = _pixels(png, (720, 520))
    assert ", 2 material(s)," in stdout
    # One column per material: each half of the image holds a plot of its own.
    assert pixels[:, :360].std() > MIN_STD
    assert pixels[:, 360:].std() > MIN_STD


@pytest.mark.gl
def test_scene_file(runs: dict[str, tuple[Path, str]]) -> None:
    png, stdout = runs["scene"]
    pixels = _pixels(png, (720, 520))
    assert ", 2 material(s)," in stdout  # both of the scene's materials
    assert pixels[:, :360].std() > MIN_STD
    assert pixels[:, 360:].std() > MIN_STD


# -- arguments -------------------------------------------------------------------------------


def test_argument_forms(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE, encoding="utf-8")
    [gold] = parse_material_arg("gold")
    assert (gold.name, gold.params.metallic, gold.params.roughness) == ("gold", 1.0, 0.5)
    assert [m.name for m in parse_material_arg(str(scene))] == ["chrome", "clay"]
    [clay] = parse_material_arg(f"{scene}:clay")
    assert clay.params.roughness == 0.9
    [floor] = parse_material_arg("showcase:floor")  # a bundled scene by name
    assert floor.params.roughness == 0.8
    [inline] = parse_material_arg(INLINE)
    assert inline.params.base_color == (0.7, 0.1, 0.1)
    assert inline.params.model.describe() == "standard"


BAD = [
    # (arguments, what the one error line must contain)
    (["nosuch"], "nosuch: preset: not a preset, a scene file or an inline"),
    (["gold", "{ roughness = nan }"], "{ roughness = nan }: roughness: Input should be a finite"),
    (["{ roughnes = 0.3 }"], "{ roughnes = 0.3 }: roughnes: unknown key"),
    (["{ roughness = 0.3"], "{ roughness = 0.3: malformed inline TOML table"),
    (["{ roughness = 2.0 }"], "roughness: Input should be less than or equal to 1"),
    (['{ preset = "nope" }'], "preset: unknown preset 'nope'"),
    (["missing.toml"], "missing.toml: no such file"),
    (["malformed.toml"], "malformed.toml: malformed TOML"),
    (["unknown-key.toml"], "unknown-key.toml: materials.a.roughnes: unknown key"),
    (["nan.toml"], "nan.toml: materials.a.roughness: Input should be a finite number"),
    (["folder"], "folder: is a folder, not a scene file"),
    (["valid.toml:b"], "valid.toml: materials.b: no such material (known: a)"),
    (["gold", "--theta", "0,nan"], "argument --theta: expected comma-separated angles"),
    (["gold", "--size", "0x10"], "argument --size: expected WIDTHxHEIGHT"),
]


@pytest.mark.parametrize(("argv", "fragment"), BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_exits_2_and_writes_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    fragment: str,
) -> None:
    (tmp_path / "malformed.toml").write_text("[materials.a\n", encoding="utf-8")
    (tmp_path / "unknown-key.toml").write_text("[materials.a]\nroughnes = 0.3\n", "utf-8")
    (tmp_path / "nan.toml").write_text("[materials.a]\nroughness = nan\n", encoding="utf-8")
    (tmp_path / "valid.toml").write_text("[materials.a]\nroughness = 0.3\n", "utf-8")
    (tmp_path / "folder").mkdir()
    before = set(tmp_path.iterdir())
    monkeypatch.chdir(tmp_path)
    rc = main(["brdf", *argv, "-o", "out/plot.png"])
    err = capsys.readouterr().err
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("pbs: error: ")
    assert fragment in lines[0]
    assert set(tmp_path.iterdir()) == before  # no output, no temp file, no folder


def test_bad_input_end_to_end(tmp_path: Path) -> None:
    proc = _app("gold", "{ metallic = inf }", "-o", "plot.png", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.splitlines() == [
        "pbs: error: { metallic = inf }: metallic: Input should be a finite number (got inf)"
    ]
    assert list(tmp_path.iterdir()) == []


def test_output_must_be_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["brdf", "gold", "-o", str(tmp_path / "plot.jpg")])
    assert rc == 2
    assert "-o: the output must be a .png file" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# -- the numbers behind the panels ------------------------------------------------------------


def _material(text: str) -> NamedMaterial:
    [m] = parse_material_arg(text)
    return m


WHITE = "{ base_color = [1, 1, 1], metallic = 0.0, f0 = 0.0, roughness = 1.0 }"
BLACK = "{ base_color = [0, 0, 0], metallic = 0.0, f0 = 0.0, roughness = 1.0 }"


def test_white_lambert_albedo_is_1(gl: GLContext) -> None:
    """The Lambert lobe rho/pi with rho = 1 reflects all light at every angle (seed sec. 3).

    f0 = 0 does not remove the specular lobe of the standard model: Schlick's F is then
    (1 - l.h)^5, which adds up to +0.048 at grazing (measured, below). f is linear in
    base_color when metallic = 0, so white minus black is exactly the Lambert lobe.
    """
    white = albedo_curve(_material(WHITE), gl=gl)
    black = albedo_curve(_material(BLACK), gl=gl)
    lambert = white.albedo - black.albedo
    assert np.abs(lambert - 1.0).max() <= 1e-3  # measured 5e-8 (GLSL), 5e-15 (float64)
    assert white.error.max() <= 1e-4  # measured 3e-5
    # The literal white "Lambert" material: 1 to 1e-3 up to 45 degrees, then the
    # specular of F = (1 - l.h)^5 lifts it, monotonically, to 1.048 at 90 degrees.
    r = white.luminance
    assert np.abs(r[white.theta <= 45.0] - 1.0).max() <= 1e-3
    assert np.all(np.diff(r) > -1e-7)
    assert 1.04 < r[-1] < 1.06


def test_smooth_dielectric_specular_raises_albedo_at_grazing(gl: GLContext) -> None:
    """A mirror-smooth dielectric (r = 0, so alpha = 0.045^2) reflects its Fresnel
    reflectance: R(theta) - 1 = F_schlick(0.04, cos theta) on top of the white Lambert lobe,
    within 1e-3 up to 80 degrees (measured 2.5e-4: GGX's small single-scattering loss)."""
    theta = np.array([0.0, 30.0, 60.0, 70.0, 80.0, 85.0, 89.0])
    smooth = albedo_curve(
        _material("{ base_color = [1, 1, 1], metallic = 0.0, f0 = 0.04, roughness = 0.0 }"),
        theta,
        gl=gl,
    )
    specular = smooth.luminance - 1.0
    fresnel = F_schlick(np.array([0.04]), np.cos(np.radians(theta)))[:, 0]
    near = theta <= 80.0
    assert np.abs(specular[near] - fresnel[near]).max() <= 1e-3
    assert abs(specular[0] - 0.04) <= 1e-4
    assert specular[-2] > 0.6  # 85 degrees: measured 0.648
    assert np.all(np.diff(smooth.luminance) > 0.0)


def test_ggx_albedo_closed_forms(gl: GLContext) -> None:
    """GGX at alpha = 1 is D = 1/pi: with F = 1 (white metal) the albedo is 1 - ln 2 head-on
    (G2 = 2 cos/(1 + cos)) and 1 - MIN_N_DOT_V/2 at grazing (V -> 1/(2 n.v), n.v clamped)."""
    curve = albedo_curve(
        _material("{ base_color = [1, 1, 1], metallic = 1.0, roughness = 1.0 }"),
        np.array([0.0, 90.0]),
        gl=gl,
    )
    expected = np.array([1.0 - math.log(2.0), 1.0 - 0.5 * MIN_N_DOT_V])
    # float32 in the shader: measured 3e-8 and 1e-8 off.
    np.testing.assert_allclose(curve.albedo, np.repeat(expected[:, None], 3, 1), atol=1e-6)


def test_quadrature_error_estimate_is_honest() -> None:
    """The reported error |R_8192 - R_2048| against a 4x finer rule, for a broad and a
    mirror-smooth lobe (float64 twin): the fine rule is within max(estimate, 1e-5).
    The estimate may undershoot at exactly 90 degrees for r = 0 (measured 3.4e-6 true vs
    3.2e-6 estimated, where the n.v clamp's kink meets the peak), hence the 1e-5 floor."""
    theta = np.array([0.0, 45.0, 80.0, 88.0, 89.5, 90.0])
    for text in ("gold", "{ roughness = 0.0 }"):
        m = _material(text)
        curve = albedo_curve(m, theta, backend="reference")
        finer = albedo_curve(m, theta, backend="reference", fine=32, coarse=16)
        true = np.abs(curve.albedo - finer.albedo).max(axis=-1)
        assert np.all(true <= np.maximum(curve.error, 1e-5)), text
        assert curve.error.max() <= 1e-4
    assert ALBEDO_THETAS[0] == 0.0 and ALBEDO_THETAS[-1] == 90.0  # the plotted range


def test_lobe_peaks_at_the_mirror_direction(gl: GLContext) -> None:
    """The lobe samples resolve a mirror-smooth peak (~0.3 degrees wide at half maximum: the
    0.25-degree uniform grid alone misses its top by up to 40%) at any theta_i: the curve's
    maximum is at theta_v = theta_i and equals f cos(theta_v) evaluated exactly there;
    head-on it is F0 D(0) V + rho/pi = 0.04/(4 pi alpha^2) + 0.8/pi (G2 = 1 to 1e-5)."""
    m = _material("{ roughness = 0.0 }")
    thetas = (0.0, 33.1, 61.7)  # off the uniform grid but 0
    for lobe in lobes(m, thetas, gl=gl):
        peak = lobe.theta_v[np.argmax(lobe.value[:, 1])]
        assert abs(peak - lobe.theta_i) < 0.01
        t = math.radians(lobe.theta_i)
        mirror = evaluate(m.params, incident(lobe.theta_i), outgoing([lobe.theta_i]), gl=gl)
        # Same GLSL at the same direction pair: equal up to float32 rounding of v.
        assert lobe.value[:, 1].max() == pytest.approx(mirror[0, 1] * math.cos(t), rel=1e-3)
    alpha = 0.045**2
    head_on = 0.04 / (4.0 * math.pi * alpha * alpha) + 0.8 / math.pi
    # The peak node sits at theta_v = 0 exactly (u = 0); float32 D: measured 2e-7 off.
    assert lobes(m, (0.0,), gl=gl)[0].value[:, 1].max() == pytest.approx(head_on, rel=1e-4)


@pytest.mark.gl
def test_the_default_context_survives_an_osmesa_context() -> None:
    """``evaluate`` without a context uses one per process; an OSMesa context created and
    destroyed meanwhile (as the test modules' ``gl`` fixture does) takes Mesa's dispatch
    from it, and its next program failed ("cannot create program", a flaky CI failure):
    the default context is made again after OSMesa came or went (app/gl/context.py)."""
    from app.gl.context import create_context

    material = {"base_color": [0.5, 0.5, 0.5], "roughness": 0.5}
    l, v = np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.6, 0.8]])
    before = evaluate(material, l, v)
    try:
        other = create_context("osmesa")
    except Exception as exc:  # OSMesa is installed by scripts/dev.sh
        pytest.fail(f"no OSMesa context: {exc}")
    other.release()
    assert np.array_equal(evaluate(material, l, v), before)
