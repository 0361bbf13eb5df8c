"""Bad input never crashes ``pbs render``: exit code 2, one line naming file and key, no output.

Most cases call ``app.cli.main`` in-process (it returns the exit code and fails before any
GL work); a few run ``python -m app`` in a subprocess to prove the contract end to end,
including the mesh-file cases that only fail once rendering has begun.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from app.cli import main
from app.gl.context import GLContext

REPO = Path(__file__).resolve().parent.parent
SIZE = "64x48"

# A minimal valid scene; each case appends to it or replaces it.
BASE = """\
[materials.m]
roughness = 0.5

[[objects]]
shape = "sphere"
material = "m"

[[lights]]
type = "point"
position = [0.0, 2.0, 2.0]
"""

SPOT = '[[lights]]\ntype = "spot"\nposition = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\n'


def _scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture
def work(tmp_path: Path) -> tuple[Path, Path]:
    """(folder for scene files, empty folder for the outputs), symlinks resolved."""
    root = tmp_path.resolve()
    out = root / "out"
    out.mkdir()
    return root, out


def _check(rc: int, stderr: str, out_dir: Path, prefix: str, fragment: str = "") -> str:
    """The bad-input contract; returns the one error line."""
    assert rc == 2, stderr
    assert "Traceback" not in stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    line = lines[0]
    assert line.startswith(prefix), line
    assert fragment in line, line
    assert sorted(p.name for p in out_dir.iterdir()) == [], "output or temp file left behind"
    return line


def _run_inproc(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    capsys.readouterr()
    rc = main(["render", *argv])
    captured = capsys.readouterr()
    assert captured.out == ""
    return rc, captured.err


def _run_cli(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "app", "render", *argv],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


# (id, scene text, key path, fragment of the message)
SCENE_CASES = [
    ("unknown-top-level-key", "foo = 1\n" + BASE, "foo", "unknown key"),
    ("unknown-nested-key", BASE + "[camera]\nfov = 40.0\n", "camera.fov", "unknown key"),
    (
        "unknown-material-key",
        BASE.replace("roughness = 0.5", "rough = 0.5"),
        "materials.m.rough",
        "unknown key",
    ),
    ("string-for-number", BASE + '[camera]\nfov_y = "45"\n', "camera.fov_y", "valid number"),
    ("bool-for-number", BASE + "[camera]\nfov_y = true\n", "camera.fov_y", "valid number"),
    ("float-for-integer", BASE + "[render]\nwidth = 64.0\n", "render.width", "valid integer"),
    ("vector-too-short", BASE + "[camera]\nposition = [1.0, 2.0]\n", "camera.position", "3"),
    ("color-too-long", "background = [0.1, 0.1, 0.1, 1.0]\n" + BASE, "background", "3"),
    (
        "vector-element-string",
        BASE + '[camera]\ntarget = [0.0, "up", 0.0]\n',
        "camera.target[1]",
        "valid number",
    ),
    ("nan", BASE + "[camera]\nfov_y = nan\n", "camera.fov_y", "finite"),
    ("inf", BASE + "[camera]\nexposure = inf\n", "camera.exposure", "finite"),
    ("minus-inf-in-vector", BASE + "[camera]\nup = [0.0, -inf, 0.0]\n", "camera.up[1]", "finite"),
    ("nan-in-color", "background = [0.0, nan, 0.0]\n" + BASE, "background[1]", "finite"),
    ("inf-intensity", BASE + "intensity = inf\n", "lights[0].intensity", "finite"),
    (
        "negative-roughness",
        BASE.replace("roughness = 0.5", "roughness = -0.1"),
        "materials.m.roughness",
        "greater than or equal to 0",
    ),
    (
        "roughness-above-1",
        BASE.replace("roughness = 0.5", "roughness = 1.5"),
        "materials.m.roughness",
        "less than or equal to 1",
    ),
    (
        "f0-above-1",
        BASE.replace("roughness = 0.5", "f0 = 1.2"),
        "materials.m.f0",
        "less than or equal to 1",
    ),
    (
        "base-color-above-1",
        BASE.replace("roughness = 0.5", "base_color = [0.5, 2.0, 0.5]"),
        "materials.m.base_color[1]",
        "less than or equal to 1",
    ),
    ("ior-below-1", BASE.replace("roughness = 0.5", "ior = 0.5"), "materials.m.ior", "1"),
    (
        "f0-and-ior",
        BASE.replace("roughness = 0.5", "f0 = 0.04\nior = 1.5"),
        "materials.m.ior",
        "not both",
    ),
    (
        "unknown-preset",
        BASE.replace("roughness = 0.5", 'preset = "unobtainium"'),
        "materials.m.preset",
        "unknown preset 'unobtainium'",
    ),
    (
        "unknown-material-reference",
        BASE.replace('material = "m"', 'material = "nope"'),
        "objects[0].material",
        "unknown material 'nope'",
    ),
    (
        "primitive-without-material",
        BASE.replace('material = "m"\n', ""),
        "objects[0].material",
        "needs it",
    ),
    (
        "zero-light-direction",
        BASE + '[[lights]]\ntype = "directional"\ndirection = [0.0, 0.0, 0.0]\n',
        "lights[1].direction",
        "zero vector",
    ),
    (
        "zero-spot-direction",
        BASE + SPOT.replace("[0.0, -1.0, 0.0]", "[0.0, 0.0, 0.0]"),
        "lights[1].direction",
        "zero vector",
    ),
    ("zero-camera-up", BASE + "[camera]\nup = [0.0, 0.0, 0.0]\n", "camera.up", "zero vector"),
    (
        "camera-position-equals-target",
        BASE + "[camera]\nposition = [1.0, 1.0, 1.0]\ntarget = [1.0, 1.0, 1.0]\n",
        "camera.target",
        "must differ from position",
    ),
    (
        "camera-up-parallel-to-view",
        BASE + "[camera]\nposition = [0.0, 5.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n",
        "camera.up",
        "parallel",
    ),
    ("camera-far-before-near", BASE + "[camera]\nnear = 10.0\nfar = 1.0\n", "camera.far", ""),
    ("camera-fov-180", BASE + "[camera]\nfov_y = 180.0\n", "camera.fov_y", "less than 180"),
    (
        "spot-inner-equals-outer",
        BASE + SPOT + "inner_angle = 30.0\nouter_angle = 30.0\n",
        "lights[1].inner_angle",
        "smaller than outer_angle",
    ),
    (
        "spot-outer-below-default-inner",
        BASE + SPOT + "outer_angle = 15.0\n",
        "lights[1].inner_angle",
        "smaller than outer_angle",
    ),
    (
        "point-light-without-position",
        BASE + '[[lights]]\ntype = "point"\n',
        "lights[1].position",
        "a point light needs it",
    ),
    (
        "spot-light-without-direction",
        BASE + '[[lights]]\ntype = "spot"\nposition = [0.0, 1.0, 0.0]\n',
        "lights[1].direction",
        "a spot light needs it",
    ),
    (
        "light-without-type",
        BASE + "[[lights]]\nposition = [0.0, 1.0, 0.0]\n",
        "lights[1].type",
        "required",
    ),
    (
        "unknown-light-type",
        BASE + '[[lights]]\ntype = "area"\nposition = [0.0, 1.0, 0.0]\n',
        "lights[1].type",
        "'area'",
    ),
    (
        "range-on-directional-light",
        BASE + '[[lights]]\ntype = "directional"\ndirection = [0.0, -1.0, 0.0]\nrange = 5.0\n',
        "lights[1].range",
        "does not apply",
    ),
    ("zero-range", BASE + "range = 0.0\n", "lights[0].range", "greater than 0"),
    ("lights-as-table", '[lights]\ntype = "point"\n', "lights", "valid list"),
    (
        "negative-scale",
        BASE.replace('material = "m"\n', 'material = "m"\nscale = -1.0\n'),
        "objects[0].scale",
        "number > 0",
    ),
    (
        "zero-in-scale-vector",
        BASE.replace('material = "m"\n', 'material = "m"\nscale = [1.0, 0.0, 1.0]\n'),
        "objects[0].scale",
        "> 0",
    ),
    (
        "plane-with-3-sizes",
        BASE + '[[objects]]\nshape = "plane"\nmaterial = "m"\nsize = [1.0, 1.0, 1.0]\n',
        "objects[1].size",
        "2 numbers",
    ),
    (
        "radius-on-box",
        BASE + '[[objects]]\nshape = "box"\nmaterial = "m"\nradius = 1.0\n',
        "objects[1].radius",
        "does not apply",
    ),
    (
        "object-without-shape",
        BASE + '[[objects]]\nmaterial = "m"\n',
        "objects[1].shape",
        "required",
    ),
    ("mesh-without-file", BASE + '[[objects]]\nshape = "mesh"\n', "objects[1].file", "needs it"),
    (
        "unknown-tonemap",
        BASE + '[render]\ntonemap = "filmic"\n',
        "render.tonemap",
        "'filmic'",
    ),
    (
        "negative-aperture",
        BASE + "[camera]\naperture = -0.1\n",
        "camera.aperture",
        "greater than or equal to 0",
    ),
    (
        "zero-focus-distance",
        BASE + "[camera]\nfocus_distance = 0.0\n",
        "camera.focus_distance",
        "greater than 0",
    ),
    (
        "unknown-terms",
        BASE + '[render]\nterms = "glossy"\n',
        "render.terms",
        "'glossy'",
    ),
    (
        "missing-mesh-file",
        BASE + '[[objects]]\nshape = "mesh"\nfile = "meshes/nope.obj"\n',
        "objects[1].file",
        "no such file",
    ),
]


@pytest.mark.parametrize(
    ("text", "key", "fragment"),
    [pytest.param(*case[1:], id=case[0]) for case in SCENE_CASES],
)
def test_bad_scene(
    work: tuple[Path, Path],
    capsys: pytest.CaptureFixture[str],
    text: str,
    key: str,
    fragment: str,
) -> None:
    root, out = work
    scene = _scene(root, text)
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {scene}: {key}: ", fragment)


# Problems with the scene file itself: no key, the message says what is wrong.
def _malformed(root: Path) -> Path:
    return _scene(root, "[camera\nposition = [0.0, 0.0, 0.0]\n")


def _duplicate_key(root: Path) -> Path:
    return _scene(root, BASE + "[camera]\nfov_y = 40.0\nfov_y = 41.0\n")


def _missing(root: Path) -> Path:
    return root / "nope.toml"


def _folder(root: Path) -> Path:
    (root / "folder.toml").mkdir()
    return root / "folder.toml"


def _not_utf8(root: Path) -> Path:
    path = root / "latin1.toml"
    path.write_bytes(BASE.encode() + b"# caf\xe9\n")
    return path


FILE_CASES = [
    ("malformed-toml", _malformed, "malformed TOML"),
    ("duplicate-key", _duplicate_key, "malformed TOML"),
    ("missing-scene-file", _missing, "no such file"),
    ("folder-as-scene", _folder, "is a folder"),
    ("not-utf8", _not_utf8, "not UTF-8"),
]


@pytest.mark.parametrize(
    ("make", "fragment"), [pytest.param(*case[1:], id=case[0]) for case in FILE_CASES]
)
def test_bad_scene_file(
    work: tuple[Path, Path], capsys: pytest.CaptureFixture[str], make, fragment: str
) -> None:
    root, out = work
    scene = make(root)
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {scene}: {fragment}")


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can read any file"
)
def test_unreadable_scene_file(work: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    root, out = work
    scene = _scene(root, BASE)
    scene.chmod(0)
    try:
        rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    finally:
        scene.chmod(0o644)
    _check(rc, err, out, f"pbs: error: {scene}: permission denied")


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can read any file"
)
def test_unreadable_mesh_file(work: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    root, out = work
    mesh = root / "locked.obj"
    mesh.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = _scene(root, BASE + '[[objects]]\nshape = "mesh"\nfile = "locked.obj"\n')
    mesh.chmod(0)
    try:
        rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    finally:
        mesh.chmod(0o644)
    _check(rc, err, out, f"pbs: error: {scene}: objects[1].file: ", "cannot read")


# OBJ faces whose index names no element or is no number: trimesh refuses a vertex past
# the end or a word with a bare IndexError or ValueError, and reads an index 0 as the last
# vertex and a texture coordinate or normal past the end as none, silently: (id, the faces
# after four vertices, one normal and one texture coordinate, the line's words expected).
BAD_FACES = [
    (
        "past-the-end",
        "f 1 2 3\nf 2 4 6\n",
        "line 8: face index 6 ('6') names no vertex (4 vertices",
    ),
    ("negative", "f 1 2 3\nf -1 -2 -9\n", "line 8: face index -9 ('-9') names no vertex"),
    ("not-a-number", "f 1//1 2//1 3//1\nf 2//1 4//1 x\n", "line 8: face word 'x' is not a whole"),
    ("zero", "f 1 2 3\nf 0 2 3\n", "line 8: face index 0 ('0') names no vertex"),
    ("uv-zero", "f 1/1 2/1 3/0\n", "line 7: face index 0 ('3/0') names no texture coordinate"),
    (
        "uv-past-the-end",
        "f 1/1 2/1 3/2\n",
        "line 7: face index 2 ('3/2') names no texture coordinate (1 texture coordinate in",
    ),
    (
        "uv-negative",
        "f 1/1 2/-1 3/-2\n",
        "line 7: face index -2 ('3/-2') names no texture coordinate (1 texture coordinate before",
    ),
    ("normal-zero", "f 1//1 2//0 3//1\n", "line 7: face index 0 ('2//0') names no normal"),
    (
        "normal-past-the-end",
        "f 1/1/1 2/1/1 3/1/2\n",
        "line 7: face index 2 ('3/1/2') names no normal (1 normal in the file",
    ),
    ("normal-negative", "f 1//1 2//-3 3//1\n", "line 7: face index -3 ('2//-3') names no normal"),
]


@pytest.mark.parametrize(("faces", "words"), [pytest.param(*c[1:], id=c[0]) for c in BAD_FACES])
def test_obj_face_index_out_of_range(
    work: tuple[Path, Path], capsys: pytest.CaptureFixture[str], faces: str, words: str
) -> None:
    """One line naming the scene, the object, the OBJ file, the line and the index (not
    trimesh's 'IndexError: index 5 is out of bounds for axis 0 with size 4'); as a model
    file (``pbs render bad.obj``), the OBJ file alone."""
    root, out = work
    mesh = root / "bad.obj"
    mesh.write_bytes(f"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvt 0 0\n{faces}".encode())
    scene = _scene(root, BASE + '[[objects]]\nshape = "mesh"\nfile = "bad.obj"\n')
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {scene}: objects[1].file: {mesh}: ", words)
    rc, err = _run_inproc(capsys, str(mesh), "-o", str(out / "out.png"), "--size", SIZE)
    line = _check(rc, err, out, f"pbs: error: {mesh}: ", words)
    assert "Error" not in line, line


def test_mesh_file_is_a_folder(work: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    root, out = work
    (root / "folder.obj").mkdir()
    scene = _scene(root, BASE + '[[objects]]\nshape = "mesh"\nfile = "folder.obj"\n')
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {scene}: objects[1].file: ", "folder.obj")


# Command-line arguments: (id, extra arguments, output name, expected prefix, fragment).
ARG_CASES = [
    ("size-zero", ["--size", "0x48"], "out.png", "pbs: error: argument --size: ", "'0x48'"),
    ("size-one-number", ["--size", "64"], "out.png", "pbs: error: argument --size: ", "'64'"),
    ("size-too-big", ["--size", "64x99999"], "out.png", "pbs: error: argument --size: ", ""),
    ("size-words", ["--size", "big"], "out.png", "pbs: error: argument --size: ", "'big'"),
    ("unknown-backend", ["--backend", "vulkan"], "out.png", "pbs: error: argument --backend", ""),
    ("output-not-png", [], "out.jpg", "pbs: error: {out}/out.jpg: -o: ", ".png"),
    ("output-no-suffix", [], "out", "pbs: error: {out}/out: -o: ", ".png"),
    ("hdr-tiff", ["--hdr", "{out}/out.tiff"], "out.png", "pbs: error: {out}/out.tiff: --hdr: ", ""),
    (
        "hdr-upper-case",
        ["--hdr", "{out}/out.EXR"],
        "out.png",
        "pbs: error: {out}/out.EXR: --hdr: ",
        ".exr or .npy",
    ),
]


@pytest.mark.parametrize(
    ("extra", "name", "prefix", "fragment"),
    [pytest.param(*case[1:], id=case[0]) for case in ARG_CASES],
)
def test_bad_arguments(
    work: tuple[Path, Path],
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    name: str,
    prefix: str,
    fragment: str,
) -> None:
    root, out = work
    scene = _scene(root, BASE)
    argv = [str(scene), "-o", str(out / name), *(a.format(out=out) for a in extra)]
    rc, err = _run_inproc(capsys, *argv)
    _check(rc, err, out, prefix.format(out=out), fragment)


def test_missing_output_argument(
    work: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    root, out = work
    rc, err = _run_inproc(capsys, str(_scene(root, BASE)))
    _check(rc, err, out, "pbs: error: ", "-o/--output")


# ---- end to end, in a subprocess -------------------------------------------------------


def test_valid_scene_renders(work: tuple[Path, Path]) -> None:
    """The control: BASE itself is fine, so each case above fails for its own reason."""
    root, out = work
    result = _run_cli(str(_scene(root, BASE)), "-o", str(out / "out.png"), "--size", SIZE, "-q")
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert sorted(p.name for p in out.iterdir()) == ["out.png"]


E2E_CASES = [
    ("malformed-toml", "[camera\n", "", "malformed TOML"),
    ("unknown-nested-key", BASE + "[camera]\nfov = 40.0\n", "camera.fov", "unknown key"),
    ("nan", BASE + "[camera]\nfov_y = nan\n", "camera.fov_y", "finite"),
    (
        "spot-inner-ge-outer",
        BASE + SPOT + "inner_angle = 40.0\nouter_angle = 30.0\n",
        "lights[1].inner_angle",
        "",
    ),
]


@pytest.mark.parametrize(
    ("text", "key", "fragment"), [pytest.param(*case[1:], id=case[0]) for case in E2E_CASES]
)
def test_bad_scene_subprocess(work: tuple[Path, Path], text: str, key: str, fragment: str) -> None:
    root, out = work
    scene = _scene(root, text)
    result = _run_cli(str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    assert result.stdout == ""
    prefix = f"pbs: error: {scene}: {key}: " if key else f"pbs: error: {scene}: "
    _check(result.returncode, result.stderr, out, prefix, fragment)


def test_bad_size_subprocess(work: tuple[Path, Path]) -> None:
    root, out = work
    result = _run_cli(str(_scene(root, BASE)), "-o", str(out / "out.png"), "--size", "0x0")
    _check(result.returncode, result.stderr, out, "pbs: error: argument --size: ", "'0x0'")


def test_missing_scene_subprocess(work: tuple[Path, Path]) -> None:
    root, out = work
    result = _run_cli(str(root / "nope.toml"), "-o", str(out / "out.png"), "--size", SIZE)
    _check(result.returncode, result.stderr, out, f"pbs: error: {root / 'nope.toml'}: ")


# Mesh files that exist but do not hold triangles trimesh can read. These fail only once
# rendering has begun (the GL context exists), so they run in a subprocess.
MESH_CASES = [
    ("binary-garbage-obj", "garbage.obj", b"v 0 0 0\nf 1 2 3\n\x00\x81\xfe\xff" * 8),
    ("text-garbage-obj", "garbage.obj", b"this is not a mesh\nat all\n"),
    ("obj-without-faces", "points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
    ("empty-obj", "empty.obj", b""),
    ("random-bytes-glb", "garbage.glb", bytes(range(256)) * 2),
    ("truncated-glb", "truncated.glb", b"glTF\x02\x00\x00\x00\x40\x00\x00\x00"),
    ("unknown-mesh-suffix", "mesh.xyzzy", b"v 0 0 0\n"),
]


@pytest.mark.parametrize(
    ("name", "data"), [pytest.param(*case[1:], id=case[0]) for case in MESH_CASES]
)
def test_bad_mesh_file(work: tuple[Path, Path], name: str, data: bytes) -> None:
    root, out = work
    (root / name).write_bytes(data)
    scene = _scene(root, BASE + f'[[objects]]\nshape = "mesh"\nfile = "{name}"\n')
    result = _run_cli(str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    line = _check(result.returncode, result.stderr, out, f"pbs: error: {scene}: objects[1].file: ")
    assert name in line


def test_output_is_a_folder(work: tuple[Path, Path]) -> None:
    """The write itself fails (after rendering): no temp file may be left beside it."""
    root, out = work
    (out / "out.png").mkdir()
    result = _run_cli(str(_scene(root, BASE)), "-o", str(out / "out.png"), "--size", SIZE)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    (out / "out.png").rmdir()  # so that _check sees an empty folder
    _check(result.returncode, result.stderr, out, f"pbs: error: {out / 'out.png'}: -o: ")


@pytest.mark.parametrize(
    "text",
    [
        pytest.param(BASE + "[camera]\nfov_y = nan\n", id="bad-scene"),
        pytest.param(
            BASE + '[[objects]]\nshape = "mesh"\nfile = "garbage.glb"\n',
            id="bad-mesh-while-rendering",
        ),
    ],
)
def test_existing_output_survives(work: tuple[Path, Path], text: str) -> None:
    root, out = work
    (root / "garbage.glb").write_bytes(b"not a glb at all")
    png, hdr = out / "out.png", out / "out.npy"
    png.write_bytes(b"sentinel png")
    hdr.write_bytes(b"sentinel hdr")
    result = _run_cli(str(_scene(root, text)), "-o", str(png), "--hdr", str(hdr), "--size", SIZE)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.splitlines()) == 1, result.stderr
    assert png.read_bytes() == b"sentinel png"
    assert hdr.read_bytes() == b"sentinel hdr"
    assert sorted(p.name for p in out.iterdir()) == ["out.npy", "out.png"]


# Sizes past what the GL can allocate (app/render/limits.py): refused after the context
# exists and before any target does, so they run in a subprocess.
@pytest.mark.parametrize(
    ("render", "size", "fragment"),
    [
        pytest.param("", "16384x16384", "GiB of render targets", id="past-memory"),
        pytest.param(
            "[render]\nsupersample = 4\n", "8192x64", "largest render target", id="past-dims"
        ),
    ],
)
def test_size_past_gl_limits(
    work: tuple[Path, Path], render: str, size: str, fragment: str
) -> None:
    root, out = work
    scene = _scene(root, BASE + render)
    result = _run_cli(str(scene), "-o", str(out / "out.png"), "--size", size)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    line = _check(result.returncode, result.stderr, out, f"pbs: error: {scene}: --size: ", fragment)
    assert size in line


def test_renderer_refuses_resize_past_limits(gl_egl: GLContext, tmp_path: Path) -> None:
    """The check is the Renderer's (viewer and API get it too): a refused resize raises
    InputError and leaves the renderer at its old size, still rendering."""
    from app.errors import InputError
    from app.render.limits import max_dimension
    from app.render.renderer import Renderer
    from app.scene.loader import load_scene

    renderer = Renderer(gl_egl, load_scene(_scene(tmp_path, BASE)), (32, 24))
    try:
        too_wide = max_dimension(gl_egl.ctx) + 1
        with pytest.raises(InputError, match=f"render size {too_wide}x24"):
            renderer.resize((too_wide, 24))
        assert renderer.size == (32, 24)
        renderer.render()
        assert renderer.read_ldr().shape[:2] == (24, 32)
    finally:
        renderer.release()


# Files a mesh file names (app/scene/references.py). The glTF is written by hand: a quad
# whose buffer and base colour image are separate files (trimesh's exporter embeds both).
def _gltf(folder: Path, name: str = "model.gltf", **doc_changes: object) -> Path:
    """A textured quad as ``name`` (.gltf with quad.bin and tex.png beside it, or a .glb
    with the buffer inside and tex.png beside it); ``doc_changes`` update the JSON."""
    import json
    import struct

    import numpy as np
    from PIL import Image

    pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    blob = pos.tobytes() + uv.tobytes() + np.array([0, 1, 2, 0, 2, 3], np.uint16).tobytes()
    Image.new("RGB", (2, 2), (255, 0, 0)).save(folder / "tex.png")
    glb = name.endswith(".glb")
    buffer: dict[str, object] = {"byteLength": len(blob)}
    if not glb:
        (folder / "quad.bin").write_bytes(blob)
        buffer["uri"] = "quad.bin"
    views = [(0, 48), (48, 32), (80, 12)]
    doc: dict[str, object] = {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [
            {
                "primitives": [
                    {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}
                ]
            }
        ],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [{"uri": "tex.png"}],
        "buffers": [buffer],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 4,
                "type": "VEC3",
                "min": [-1, -1, 0],
                "max": [1, 1, 0],
            },
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        **doc_changes,
    }
    path = folder / name
    if not glb:
        path.write_text(json.dumps(doc), encoding="utf-8")
        return path
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(blob), 0x004E4942) + blob
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
    return path


def _remove(name: str) -> Callable[[Path], None]:
    return lambda root: (root / name).unlink()


def _garble(name: str) -> Callable[[Path], None]:
    return lambda root: (root / name).write_bytes(b"not a PNG at all")


REQUIRED = "extensionsRequired"
# (id, mesh file name, glTF JSON changes, what is done to the files, fragment of the line)
REFERENCE_CASES = [
    ("gltf-image-missing", "model.gltf", {}, _remove("tex.png"), "images[0].uri 'tex.png'"),
    ("gltf-buffer-missing", "model.gltf", {}, _remove("quad.bin"), "buffers[0].uri 'quad.bin'"),
    ("gltf-image-garbage", "model.gltf", {}, _garble("tex.png"), "tex.png: is not an image"),
    ("glb-image-missing", "model.glb", {}, _remove("tex.png"), "images[0].uri 'tex.png'"),
    ("gltf-draco-bad-view", "model.gltf", {REQUIRED: ["KHR_draco_mesh_compression"],
     "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "extensions": {
         "KHR_draco_mesh_compression": {"bufferView": 7, "attributes": {"POSITION": 0}}}}]}]},
     None, "KHR_draco_mesh_compression.bufferView: 7 is not one of the 3"),
    ("glb-meshopt-garbage", "model.glb", {REQUIRED: ["EXT_meshopt_compression"],
     "bufferViews": [{"buffer": 0, "byteLength": 48, "extensions": {"EXT_meshopt_compression": {
         "buffer": 0, "byteLength": 48, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}}},
         {"buffer": 0, "byteOffset": 48, "byteLength": 32},
         {"buffer": 0, "byteOffset": 80, "byteLength": 12}]},
     None, "EXT_meshopt_compression"),
    ("gltf-unknown-required", "model.gltf", {REQUIRED: ["EXT_made_up"]}, None,
     "extension EXT_made_up"),
    ("gltf-points-only", "model.gltf",
     {"meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": 0}]}]}, None,
     "holds no triangles"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("name", "changes", "damage", "fragment"),
    [pytest.param(*case[1:], id=case[0]) for case in REFERENCE_CASES],
)
@pytest.mark.gl
def test_bad_gltf_references(
    work: tuple[Path, Path],
    capsys: pytest.CaptureFixture[str],
    name: str,
    changes: dict[str, object],
    damage: Callable[[Path], None] | None,
    fragment: str,
) -> None:
    """trimesh would load these without the file (white) or draw nothing: exit 2 instead,
    naming the scene, the object and the missing file or the extension."""
    root, out = work
    _gltf(root, name, **changes)
    if damage is not None:
        damage(root)
    scene = _scene(root, BASE + f'[[objects]]\nshape = "mesh"\nfile = "{name}"\n')
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {scene}: objects[1].file: {root / name}", fragment)


def test_intact_gltf_and_data_uris_render(work: tuple[Path, Path]) -> None:
    """The same files intact render (exit 0), and data: URIs are not files to look for."""
    import base64

    root, out = work
    _gltf(root)
    data = base64.b64encode((root / "quad.bin").read_bytes()).decode()
    (root / "quad.bin").unlink()
    doc_uri = {"uri": f"data:application/octet-stream;base64,{data}", "byteLength": 92}
    _gltf(root, "inline.gltf", buffers=[doc_uri])
    (root / "quad.bin").unlink()  # inline.gltf wrote it again: neither file may need it
    text = BASE + '[[objects]]\nshape = "mesh"\nfile = "inline.gltf"\n'
    result = _run_cli(str(_scene(root, text)), "-o", str(out / "out.png"), "--size", SIZE)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    assert result.returncode == 0, result.stderr
    assert (out / "out.png").is_file()


OBJ_QUAD = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
OBJ_QUAD += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"


@pytest.mark.parametrize(
    ("mtl", "fragment"),
    [
        pytest.param(None, "mtllib quad.mtl: ", id="mtl-missing"),
        pytest.param("newmtl m\nKd 1 1 1\nmap_Kd -s 1 1 1 gone.png\n", "map_Kd gone.png",
                     id="map-kd-missing"),
        pytest.param("newmtl m\nmap_Pr gone.png\n", "map_Pr gone.png", id="map-pr-missing"),
        pytest.param("newmtl m\nmap_Pm gone.png\n", "map_Pm gone.png", id="map-pm-missing"),
        pytest.param("newmtl m\nnorm -bm 2 my gone.png\n", "norm my gone.png",
                     id="norm-missing"),
        pytest.param("newmtl m\nmap_Ke gone.png\n", "map_Ke gone.png", id="map-ke-missing"),
        pytest.param("newmtl m\nmap_d gone.png\n", "map_d gone.png", id="map-d-missing"),
    ],
)  # fmt: skip
@pytest.mark.gl
def test_bad_obj_references(
    work: tuple[Path, Path], capsys: pytest.CaptureFixture[str], mtl: str | None, fragment: str
) -> None:
    """trimesh gives an OBJ whose MTL is gone a grey material with a white image: exit 2."""
    root, out = work
    (root / "quad.obj").write_text("mtllib quad.mtl\nusemtl m\n" + OBJ_QUAD, encoding="utf-8")
    if mtl is not None:
        (root / "quad.mtl").write_text(mtl, encoding="utf-8")
    scene = _scene(root, BASE + '[[objects]]\nshape = "mesh"\nfile = "quad.obj"\n')
    rc, err = _run_inproc(capsys, str(scene), "-o", str(out / "out.png"), "--size", SIZE)
    line = _check(rc, err, out, f"pbs: error: {scene}: objects[1].file: {root / 'quad.obj'}")
    assert fragment in line and "no such file" in line, line


def test_compare_size_past_gl_limits(work: tuple[Path, Path]) -> None:
    """Both sides of --compare are Renderers: the same refusal, naming --size."""
    root, out = work
    scene = _scene(root, BASE)
    compare = ("--compare", "materials.m.roughness=0.2,0.8")
    result = _run_cli(str(scene), "-o", str(out / "out.png"), "--size", "16384x16384", *compare)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    _check(result.returncode, result.stderr, out, f"pbs: error: {scene}: --size: ", "GiB")


# Sound OBJ faces in the forms the fast screen leaves to the line reading (relative
# indices, an indented statement, a comment on a face line, CRLF) and in the plain one.
SOUND_FACES = [
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf -3/-1/-1 -2/-1/-1 -1/-1/-1\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\n  f 1 2 3\nf 1 2 3 # a comment\n",
    "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvn 0 0 1\r\nf 1//1 2//1 3//1\r\n",
]


@pytest.mark.parametrize("text", SOUND_FACES)
def test_obj_sound_faces_pass(text: str) -> None:
    """The face check refuses no sound face, whichever reading decides."""
    from app.scene.references import obj_index_problem

    assert obj_index_problem(Path("sound.obj"), text.encode()) is None
    assert (
        obj_index_problem(Path("teapot.obj"), (REPO / "scenes/meshes/teapot.obj").read_bytes())
        is None
    )


OBJ_HEAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvt 0 0\n"


@pytest.mark.parametrize(
    "faces",
    [pytest.param(c[1], id=c[0]) for c in BAD_FACES]
    + [
        pytest.param("f 1 2 3\nf\x0b0 1 2\nf 1 2 4\n", id="vertical-tab"),
        pytest.param("f 1 2 3\nf\x1c0 1 2\n", id="file-separator"),
        pytest.param("f 1 2 3\nf\u00a00 1 2\n", id="no-break-space"),
    ],
)
def test_obj_fast_screen_never_vouches_for_a_bad_face(faces: str) -> None:
    """The numpy screen says False for every face the line reading refuses (it may only
    err the safe way), a face after a vertical tab, a file separator or a no-break space
    included (trimesh splits on every Unicode blank, so it reads those as faces and their
    0 as the last vertex), and the line reading then names it."""
    from app.scene.references import _obj_faces_plain, obj_index_problem

    data = (OBJ_HEAD + faces).encode()
    assert not _obj_faces_plain(data)
    assert obj_index_problem(Path("bad.obj"), data) is not None


def test_obj_fast_screen_vouches_for_plain_files_across_chunks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The screen passes plainly sound files itself (the teapot, and a file read in many
    chunks of whole lines), so the line reading stays the exception; a bad index in a
    later chunk, past the file's count or 0, is still caught there."""
    from app.scene import references

    teapot = (REPO / "scenes/meshes/teapot.obj").read_bytes()
    assert references._obj_faces_plain(teapot)
    monkeypatch.setattr(references, "_SCREEN_CHUNK", 64)
    faces = "".join(f"f {i} {i + 1} {i + 2}\n" for i in range(1, 40))
    verts = "".join(f"v {i} 0 0\n" for i in range(41))
    assert references._obj_faces_plain((faces + verts).encode())  # faces before vertices
    assert not references._obj_faces_plain((faces + "f 1 2 42\n" + verts).encode())
    assert not references._obj_faces_plain((verts + faces + "f 1 0 2\n").encode())


def test_obj_overlong_line_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A line longer than the screen's chunk is refused with its number before either
    reading holds it whole (a one-polygon file of hundreds of megabytes would otherwise
    take tens of bytes a byte); lines up to the limit, CR-separated ones included, pass."""
    from app.scene import references

    monkeypatch.setattr(references, "_SCREEN_CHUNK", 64)
    verts = "".join(f"v {i} 0 0\n" for i in range(30))
    long = "f " + " ".join(str(1 + i % 30) for i in range(40)) + "\n"  # 103 bytes and "\n"
    problem = references.obj_index_problem(Path("x.obj"), (verts + long + "f 1 2 3\n").encode())
    assert problem == "x.obj: line 31: a line of 103 bytes (OBJ lines are read up to 64 bytes)"
    fine = verts + "f 1 2 3\n" * 20
    assert references.obj_index_problem(Path("x.obj"), fine.encode()) is None
    assert references.obj_index_problem(Path("x.obj"), fine.replace("\n", "\r").encode()) is None
