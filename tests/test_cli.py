"""``python -m app render`` end to end: real subprocesses, real headless GL, real files.

Everything renders at 96x54 to stay quick. The checkout under test is put first on
PYTHONPATH, so these runs do not depend on how (or whether) the project is installed;
the last test builds a wheel and runs the installed copy from an unrelated folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.gl  # pbs render children (all but --help and no arguments)

REPO = Path(__file__).resolve().parent.parent
W, H = 96, 54
SIZE = f"{W}x{H}"


def _env(pythonpath: Path = REPO) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(pythonpath)
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return env


def _run(
    args: list[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = 120
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        args,
        cwd=cwd,
        env=env or _env(),
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _app(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return _run([sys.executable, "-m", "app", *argv], cwd)


def _ok(proc: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    return proc


def _png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.mode == "RGB"
        assert image.size == (W, H)
        return np.asarray(image, np.float64)


# -- backends ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def backend_pngs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    """showcase rendered once per backend: backend -> (PNG, stdout)."""
    out = tmp_path_factory.mktemp("backends")
    result = {}
    for backend in ("egl", "osmesa"):
        png = out / f"{backend}.png"
        proc = _ok(
            _app(
                "render", "showcase", "-o", str(png), "--size", SIZE, "--backend", backend, cwd=out
            )
        )
        result[backend] = (png, proc.stdout)
    return result


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_render_backend(backend_pngs: dict[str, tuple[Path, str]], backend: str) -> None:
    png, stdout = backend_pngs[backend]
    pixels = _png(png)
    assert pixels.std() > 2.0, "flat image"
    # The summary line names the size and the backend that really ran.
    assert stdout.count("\n") == 1
    assert f"{W}x{H}" in stdout
    assert f", {backend} (" in stdout


def test_backends_agree(backend_pngs: dict[str, tuple[Path, str]]) -> None:
    egl, osmesa = (_png(backend_pngs[b][0]) for b in ("egl", "osmesa"))
    # Both are Mesa llvmpipe here; measured mean |diff| = 0.0 code values.
    assert np.abs(egl - osmesa).mean() < 1.0


def test_quiet_prints_nothing(tmp_path: Path) -> None:
    proc = _ok(_app("render", "showcase", "-o", "q.png", "--size", SIZE, "-q", cwd=tmp_path))
    assert proc.stdout == ""
    assert proc.stderr == ""
    _png(tmp_path / "q.png")


def test_outputs_into_missing_folders(tmp_path: Path) -> None:
    """``-o`` and ``--hdr`` in folders that do not exist yet: the folders are made (like
    ``mkdir -p``, as ``pbs batch -o`` makes its folder); a path through a regular file
    is one error line and exit 2, with nothing written."""
    _ok(
        _app(
            "render", "showcase", "-o", "new/png/q.png", "--hdr", "other/hdr/q.npy",
            "--size", SIZE, "-q", cwd=tmp_path,
        )
    )  # fmt: skip
    _png(tmp_path / "new" / "png" / "q.png")
    assert np.load(tmp_path / "other" / "hdr" / "q.npy").shape == (H, W, 3)
    (tmp_path / "plain").write_text("not a folder", encoding="utf-8")
    proc = _app("render", "showcase", "-o", "plain/q.png", "--size", SIZE, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith("pbs: error: plain/q.png: -o: cannot write")
    assert proc.stderr.count("\n") == 1 and proc.stdout == ""


# -- HDR output -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def hdr_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("hdr")
    for suffix in ("npy", "exr"):
        _ok(
            _app(
                "render", "showcase", "-o", f"{suffix}.png", "--size", SIZE,
                "--backend", "egl", "--hdr", f"out.{suffix}", cwd=out,
            )
        )  # fmt: skip
    return {"npy": out / "out.npy", "exr": out / "out.exr", "png": out / "npy.png"}


def test_hdr_npy(hdr_files: dict[str, Path]) -> None:
    hdr = np.load(hdr_files["npy"])
    assert hdr.dtype == np.float32
    assert hdr.shape == (H, W, 3)
    assert np.isfinite(hdr).all()
    assert hdr.min() >= 0.0
    assert hdr.max() > 1.0, "showcase should have highlights above 1 (linear HDR)"
    _png(hdr_files["png"])  # the PNG is written as well


def test_hdr_exr_matches_npy(hdr_files: dict[str, Path]) -> None:
    import OpenEXR

    with OpenEXR.File(str(hdr_files["exr"])) as f:
        channels = f.channels()
        assert "RGB" in channels
        exr = np.asarray(channels["RGB"].pixels)
    assert exr.shape == (H, W, 3)
    assert exr.dtype == np.float32  # full float, not half
    npy = np.load(hdr_files["npy"])
    np.testing.assert_allclose(exr, npy, rtol=1e-6, atol=0.0)


# -- scene lookup and argument handling -------------------------------------------------


def test_bundled_scene_from_another_cwd(tmp_path: Path) -> None:
    for name in ("showcase", "teapot"):  # teapot also loads a mesh relative to its scene
        _ok(_app("render", name, "-o", f"{name}.png", "--size", SIZE, "-q", cwd=tmp_path))
        assert _png(tmp_path / f"{name}.png").std() > 2.0


def test_help_exits_0(tmp_path: Path) -> None:
    proc = _app("--help", cwd=tmp_path)
    assert proc.returncode == 0
    assert "render" in proc.stdout
    assert proc.stderr == ""
    proc = _app("render", "--help", cwd=tmp_path)
    assert proc.returncode == 0
    assert "--backend" in proc.stdout


def test_no_arguments_exits_2(tmp_path: Path) -> None:
    proc = _app(cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("pbs: error:")


def test_quiet_mesh_file_prints_nothing(tmp_path: Path) -> None:
    import trimesh

    trimesh.creation.box().export(tmp_path / "box.stl")
    (tmp_path / "scene.toml").write_text(
        '[[lights]]\ntype = "directional"\ndirection = [0.0, -1.0, -1.0]\n\n'
        '[[objects]]\nshape = "mesh"\nfile = "box.stl"\n'
    )
    proc = _ok(_app("render", "scene.toml", "-o", "box.png", "--size", SIZE, "-q", cwd=tmp_path))
    assert proc.stdout == ""
    assert proc.stderr == ""


# -- a non-editable install -------------------------------------------------------------


def _build_wheel(dest: Path) -> Path:
    """``pip wheel`` the checkout (isolated build env; without network, the local hatchling)."""
    dest.mkdir(parents=True, exist_ok=True)
    base = [sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(dest)]
    proc = _run([*base, str(REPO)], dest, timeout=300)
    if proc.returncode != 0:
        have_hatchling = _run([sys.executable, "-c", "import hatchling"], dest).returncode == 0
        if not have_hatchling:
            pytest.skip(f"cannot build a wheel (no network, no hatchling):\n{proc.stderr[-2000:]}")
        proc = _run([*base, "--no-build-isolation", str(REPO)], dest, timeout=300)
    _ok(proc)
    wheels = list(dest.glob("pbs_lab-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_wheel_install_runs_from_anywhere(tmp_path: Path) -> None:
    wheel = _build_wheel(tmp_path / "dist")
    site = tmp_path / "site"
    _ok(
        _run(
            [sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(site), wheel],
            tmp_path,
            timeout=300,
        )
    )
    assert (site / "app" / "glsl" / "brdf" / "ndf.glsl").is_file()
    assert (site / "app" / "scenes" / "showcase.toml").is_file()
    assert (site / "app" / "scenes" / "meshes" / "teapot.obj").is_file()
    assert list((site / "app" / "walkthrough_steps").glob("*.toml"))  # the lesson's steps

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = _env(site)
    probe = _ok(
        _run(
            [
                sys.executable, "-c",
                "import app, app.resources as r; print(app.__file__); "
                "print(r.glsl_dir()); print(r.scenes_dir())",
            ],
            elsewhere,
            env,
        )
    )  # fmt: skip
    for line in probe.stdout.splitlines():
        assert Path(line).resolve().is_relative_to(site.resolve()), probe.stdout

    for name in ("showcase", "teapot"):
        _ok(
            _run(
                [sys.executable, "-m", "app", "render", name, "-o", f"{name}.png", "--size", SIZE],
                elsewhere,
                env,
            )
        )
        assert _png(elsewhere / f"{name}.png").std() > 2.0
