"""The split-screen comparison (app/render/compare.py), with real GL and no mocks: each half
of a split is, bit for bit, a plain render of its side; the difference view is black where
the sides agree and lit exactly where they differ; a comparison that changes (camera,
base scene) renders what one built fresh renders; bad ``--compare`` input exits 2 with
one line and writes nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from app.errors import InputError
from app.reference.tonemap import post_process
from app.render.compare import (
    DIVIDER_COLOR,
    CompareSpec,
    Comparison,
    divider_column,
    divider_line,
    parse_compare,
)
from app.render.renderer import Renderer
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.scene.model import Camera
from tests.conftest import REPO

SIZE = (176, 55)  # sec5_metals at a fifth: each sphere about 12 pixels across
METALS = scenes_dir() / "sec5_metals.toml"
# RTR4 §9.5: the top row's gold sphere by Schlick's approximation against the exact
# conductor Fresnel equations; the divider through the sphere's middle.
GOLD = CompareSpec("materials.gold-schlick.fresnel", "schlick", "conductor")
GOLD_DIVIDER = 0.79
BRIGHTER = CompareSpec("lights[0].intensity", 1.5, 6.0)  # every sphere differs


@pytest.fixture(scope="module")
def metals() -> LoadedScene:
    return load_scene(METALS)


def plain(gl, loaded: LoadedScene) -> tuple[np.ndarray, np.ndarray]:
    """A plain headless render: (HDR, display image)."""
    r = Renderer(gl, loaded, SIZE)
    try:
        r.render()
        return r.read_hdr(), r.read_ldr()
    finally:
        r.release()


def composites(c: Comparison, divider: float = 0.5) -> tuple[np.ndarray, ...]:
    """Render, then both composites and both sides' HDR images."""
    c.render()
    c.composite("split", divider)
    split = c.read_ldr()
    c.composite("difference")
    return (split, c.read_ldr(), *c.read_sides())


# --- the spec -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "path", "a", "b"),
    [
        (
            'materials.gold.fresnel="schlick","conductor"',
            ("materials", "gold", "fresnel"),
            "schlick",
            "conductor",
        ),
        ("lights[0].intensity=0.5,2", ("lights", 0, "intensity"), 0.5, 2),
        ("materials.m.multiscatter = false, true", ("materials", "m", "multiscatter"), False, True),
        ("background=[1,0,0],[0, 0.5, 1]", ("background",), [1, 0, 0], [0, 0.5, 1]),
        ('materials."a.b=c".g2="separable","height_correlated"', ("materials", "a.b=c", "g2"),
         "separable", "height_correlated"),
        ('render.normal_filter="naive","variance"', ("render", "normal_filter"), "naive",
         "variance"),
    ],
)  # fmt: skip
def test_parse_compare_reads_toml_values(text: str, path: tuple, a: object, b: object) -> None:
    spec = parse_compare(text)
    assert (spec.path, spec.a, spec.b) == (path, a, b)
    assert type(spec.a) is type(a) and type(spec.b) is type(b)  # 2 stays an int, false a bool


@pytest.mark.parametrize(
    "text",
    [
        "materials.gold.fresnel=schlick,conductor",  # strings need quotes: no guessing
        "camera.aperture=0.1",  # one value
        "camera.aperture=0,0.1,0.2",  # three
        "camera.aperture",  # no '='
        "=1,2",  # no key
        "materials..fresnel=1,2",
        "lights[x].intensity=1,2",
        "camera.aperture=1,2]\nx=[3",  # no second line smuggled into the TOML
    ],
)
def test_parse_compare_refuses_malformed_input(text: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_compare(text)
    assert caught.value.file == "--compare"


@pytest.mark.parametrize(
    ("spec", "key"),
    [
        (CompareSpec("materials.gold.fresnel", "schlick", "conductor"), "materials.gold"),
        (CompareSpec("materials.gold-schlick.frensel", "schlick", "conductor"),
         "materials.gold-schlick.frensel"),
        (CompareSpec("materials.gold-schlick.roughness", 0.5, 2.0),
         "materials.gold-schlick.roughness"),
        (CompareSpec("materials.gold-schlick.roughness", 0.5, "rough"),
         "materials.gold-schlick.roughness"),
        (CompareSpec("lights[1].intensity", 1.0, 2.0), "lights[1]"),
        (CompareSpec("camera.aperture.x", 1.0, 2.0), "camera.aperture.x"),
        (CompareSpec("render.width", 100, 200), "render.width"),
    ],
)  # fmt: skip
def test_refused_keys_and_values_name_the_key(metals: LoadedScene, spec, key: str) -> None:
    with pytest.raises(InputError) as caught:
        spec.scenes(metals)
    assert caught.value.key == key
    assert "comparison" in caught.value.message


def test_scene_for_sets_the_key_and_nothing_else(metals: LoadedScene) -> None:
    side = GOLD.scene_for(metals, "b")
    assert side.scene.materials["gold-schlick"].fresnel == "conductor"
    data, want = side.scene.model_dump(), metals.scene.model_dump()
    want["materials"]["gold-schlick"]["fresnel"] = "conductor"
    assert data == want
    assert GOLD.scene_for(metals, "a").scene == metals.scene  # A is the file's own value


# --- split --------------------------------------------------------------------------------


@pytest.mark.parametrize(("spec", "divider"), [(GOLD, GOLD_DIVIDER), (BRIGHTER, 0.3)])
def test_split_halves_are_each_sides_plain_render(gl_egl, metals, spec, divider) -> None:
    """Left of the divider line: side A's own render, bit for bit; right of it: side B's;
    the line's columns: the divider colour. Also at the dividers 0 and 1."""
    want_a = plain(gl_egl, spec.scene_for(metals, "a"))[1]
    want_b = plain(gl_egl, spec.scene_for(metals, "b"))[1]
    c = Comparison(gl_egl, metals, spec, SIZE)
    try:
        c.render()
        for d in (divider, 0.0, 1.0):
            c.composite("split", d)
            got = c.read_ldr()
            line = divider_line(d, SIZE[0])
            column = divider_column(d, SIZE[0])
            assert line == range(max(column - 1, 0), min(column + 1, SIZE[0]))  # 2 wide
            np.testing.assert_array_equal(got[:, : line.start], want_a[:, : line.start])
            np.testing.assert_array_equal(got[:, line.stop :], want_b[:, line.stop :])
            assert (got[:, line.start : line.stop] == DIVIDER_COLOR).all()
    finally:
        c.release()
    # The sides differ on both sides of the line, so a swapped or shifted split would fail.
    line = divider_line(divider, SIZE[0])
    assert not np.array_equal(want_a[:, : line.start], want_b[:, : line.start])
    assert not np.array_equal(want_a[:, line.stop :], want_b[:, line.stop :])


# --- difference ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "spec",
    [
        CompareSpec("materials.gold-schlick.fresnel", "conductor", "conductor"),
        CompareSpec("render.tonemap", "neutral", "aces"),  # the same radiance, shown apart
    ],
)
def test_difference_of_equal_radiance_is_black(gl_egl, metals, spec) -> None:
    c = Comparison(gl_egl, metals, spec, SIZE)
    try:
        c.render()
        c.composite("difference", gain=1e6)
        assert not c.read_ldr().any()
        c.composite("split")
        assert c.read_ldr().any()  # the pass draws something
    finally:
        c.release()


def test_difference_lights_exactly_the_changed_sphere(gl_egl, metals) -> None:
    """Schlick against the exact conductor on the top row's gold sphere (RTR4 §9.5): the
    sides' radiance differs on exactly that sphere's pixels, the difference image is
    non-zero only there (and on most of them), black on the background, and equals the
    float64 twin of the post pass applied to |A - B| x gain within one 8-bit step."""
    gain = 8.0
    c = Comparison(gl_egl, metals, GOLD, SIZE)
    try:
        c.render()
        c.composite("difference", gain=gain)
        got = c.read_ldr()
        hdr_a, hdr_b = c.read_sides()
        side_a = c.renderers[0]
        gbuffer = side_a.read_gbuffer()
        objects = side_a.scene.objects
        assert len(side_a.frame.parts) == len(objects)  # one part per primitive
        index = next(i for i, o in enumerate(objects) if o.material == "gold-schlick")
        gold = gbuffer.material_id == side_a.frame.material_ids[index][0]
    finally:
        c.release()
    assert 50 < gold.sum() < 200  # one sphere, about 12 pixels across
    changed = (hdr_a != hdr_b).any(axis=2)
    np.testing.assert_array_equal(changed, gold)
    lit = got.any(axis=2)
    assert not (lit & ~gold).any()
    assert lit.sum() > 0.9 * gold.sum()
    assert not got[~gbuffer.covered].any()
    twin = post_process(np.abs(hdr_a.astype(np.float64) - hdr_b) * gain, 0.0, "neutral")
    assert np.abs(got.astype(np.int64) - np.round(twin * 255.0)).max() <= 1


# --- a comparison that changes ------------------------------------------------------------


NEW_CAMERA = Camera(
    position=[30.0, 60.0, 290.0], target=[0.5, 0.3, 0.0], fov_y=0.7, near=250.0, far=350.0
)


@pytest.mark.parametrize(
    "spec", [GOLD, CompareSpec("camera.fov_y", 0.862, 1.3)], ids=["material", "camera key"]
)
def test_set_camera_matches_a_fresh_comparison(gl_egl, metals, spec) -> None:
    """Both sides follow the camera; a camera key keeps each side's own value of it."""
    moved = parse_scene(
        {**metals.scene.model_dump(exclude_none=True), "camera": NEW_CAMERA.model_dump()},
        metals.path,
    )
    fresh = Comparison(gl_egl, moved, spec, SIZE)
    try:
        want = composites(fresh, GOLD_DIVIDER)
    finally:
        fresh.release()
    c = Comparison(gl_egl, metals, spec, SIZE)
    try:
        before = composites(c, GOLD_DIVIDER)
        c.set_camera(NEW_CAMERA)
        got = composites(c, GOLD_DIVIDER)
        fov = [s.camera.fov_y for s in c.scenes]
    finally:
        c.release()
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
    assert not np.array_equal(before[0], got[0])  # the camera moved the image
    if spec.touches("camera"):
        assert fov == [0.862, 1.3]


def test_update_base_matches_a_fresh_comparison(gl_egl, metals) -> None:
    data = metals.scene.model_dump(exclude_none=True)
    data["lights"][0]["intensity"] = 3.0
    data["materials"]["gold-schlick"]["roughness"] = 0.2
    data["render"]["tonemap"] = "aces"
    edited = parse_scene(data, metals.path)
    fresh = Comparison(gl_egl, edited, GOLD, SIZE)
    try:
        want = composites(fresh, GOLD_DIVIDER)
    finally:
        fresh.release()
    c = Comparison(gl_egl, metals, GOLD, SIZE)
    try:
        composites(c, GOLD_DIVIDER)
        c.update_base(edited.scene)
        got = composites(c, GOLD_DIVIDER)
    finally:
        c.release()
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)


def test_the_sides_compile_shared_programs_once(gl_egl, metals) -> None:
    """A key that needs no other program (a light's intensity): the comparison's one cache
    holds exactly what one renderer compiles."""
    alone = Renderer(gl_egl, metals, SIZE)
    count = len(alone.shaders)
    alone.release()
    c = Comparison(gl_egl, metals, BRIGHTER, SIZE)
    try:
        assert len(c.shaders) == count
    finally:
        c.release()


# --- the command line ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--compare", 'materials.gold.fresnel="schlick","conductor"'], "materials.gold"),
        (["--compare", 'materials.gold-schlick.fresnel="schlick","fast"'],
         "materials.gold-schlick.fresnel"),
        (["--compare", 'materials.gold-schlick.roughness="rough",0.5'],
         "materials.gold-schlick.roughness"),
        (["--compare", "materials.gold-schlick.fresnel=schlick,conductor"],
         "materials.gold-schlick.fresnel"),
        (["--compare", "camera.aperture=0,0.1", "--gain", "4"], "--gain"),
        (["--divider", "0.3"], "--divider"),
        (["--compare", "camera.aperture=0,0.1", "--divider", "1.5"], "--divider"),
        (["--compare", "camera.aperture=0,0.1", "--hdr", "x.npy"], "--hdr"),
    ],
)  # fmt: skip
def test_cli_bad_compare_input_exits_2_with_one_line(tmp_path, capsys, args, named) -> None:
    out = tmp_path / "out.png"
    code = main(["render", str(METALS), "-o", str(out), *args])
    err = capsys.readouterr()
    assert code == 2
    assert err.out == ""
    lines = err.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("pbs: error: ")
    assert named in lines[0]
    if not named.startswith("--"):  # a key: the line names the option too
        assert "--compare" in lines[0]
    assert not out.exists()


def test_cli_writes_the_comparisons_composite(gl_egl, metals, tmp_path) -> None:
    """``pbs render --compare`` (a real subprocess) writes the Python API's composite."""
    c = Comparison(gl_egl, metals, GOLD, SIZE)
    try:
        c.render()
        c.composite("difference", gain=4.0)
        want = c.read_ldr()
    finally:
        c.release()
    out = tmp_path / "diff.png"
    proc = subprocess.run(
        [sys.executable, "-m", "app", "render", str(METALS), "-o", str(out), "--size",
         f"{SIZE[0]}x{SIZE[1]}", "--compare", 'materials.gold-schlick.fresnel="schlick",'
         '"conductor"', "--compare-mode", "difference", "--gain", "4"],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)},
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "difference |A - B| x 4" in proc.stdout
    with Image.open(out) as image:
        np.testing.assert_array_equal(np.asarray(image), want)
