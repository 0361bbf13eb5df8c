"""The EGL device a context is made on (``--device``, ``PBS_EGL_DEVICE``, ``pbs devices``,
``pbs batch --devices``) and GL entry points through ``eglGetProcAddress``
(app/gl/context.py, app/gl/egl.py; docs/architecture.md "Contexts and devices").

Real EGL throughout. A machine without a GPU enumerates one device (Mesa's software
device), which cannot show a context landing on the second: where EGL is glvnd with
Mesa's vendor library, ``two_devices`` gives child processes a second copy of that
library under another name, a second vendor whose software device EGL enumerates after
the first. Each context then asks EGL which device its display is on
(``eglQueryDisplayAttribEXT``), so a device that was not passed through reads as 0.
"""

from __future__ import annotations

import ctypes
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from app.gl import egl
from app.gl.context import GLContext, gl_function
from tests.conftest import REPO
from tests.test_cli_startup import among, run_cli

pytestmark = pytest.mark.gl

VENDOR_FILES = "__EGL_VENDOR_LIBRARY_FILENAMES"  # glvnd: the vendor JSON files to load
GLVND_VENDORS = (Path("/usr/share/glvnd/egl_vendor.d"), Path("/etc/glvnd/egl_vendor.d"))
LINE = re.compile(r"(\d+): (.+); GL_VENDOR (.+); GL_RENDERER (.+)")


def _pbs(*argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """``pbs ARGV`` in a child process with ``env`` (the tree on PYTHONPATH)."""
    env = {**(os.environ if env is None else env), "PYTHONPATH": str(REPO)}
    return subprocess.run(
        [sys.executable, "-m", "app", *argv],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip


def _loaded_path(soname: str) -> Path | None:
    """The file the dynamic loader opens for ``soname`` (read from /proc/self/maps)."""
    try:
        ctypes.CDLL(soname)
    except OSError:
        return None
    maps = Path("/proc/self/maps").read_text(encoding="utf-8").splitlines()
    paths = {Path(line.split()[-1]) for line in maps if "/" in line}
    return next((p for p in paths if p.name.startswith(soname.split(".so")[0] + ".so")), None)


@pytest.fixture(scope="module")
def two_devices(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """An environment whose EGL enumerates a second device: glvnd loads Mesa's vendor
    library and a copy of it under another name. Skips where EGL is not glvnd with Mesa."""
    vendor = next((f for d in GLVND_VENDORS for f in sorted(d.glob("*mesa*.json"))), None)
    if vendor is None:
        pytest.skip("no glvnd EGL vendor file of Mesa's")
    library = json.loads(vendor.read_text(encoding="utf-8"))["ICD"]["library_path"]
    path = Path(library) if library.startswith("/") else _loaded_path(library)
    if path is None or not path.is_file():
        pytest.skip(f"Mesa's EGL vendor library {library} not found")
    folder = tmp_path_factory.mktemp("second-egl-vendor")
    copy = folder / "libEGL_mesa_second.so.0"
    shutil.copyfile(path, copy)
    second = folder / "second_mesa.json"
    icd = {"file_format_version": "1.0.0", "ICD": {"library_path": str(copy)}}
    second.write_text(json.dumps(icd), encoding="utf-8")
    env = {**os.environ, VENDOR_FILES: f"{vendor}:{second}"}
    env.pop(egl.DEVICE_ENV, None)
    return env


def _listing(env: dict[str, str] | None = None) -> list[tuple[int, str, str, str]]:
    """``pbs devices``: (index, kind, GL_VENDOR, GL_RENDERER) per line."""
    proc = _pbs("devices", env=env)
    assert proc.returncode == 0, proc.stderr
    rows = [LINE.fullmatch(line) for line in proc.stdout.splitlines()]
    assert rows and all(rows), proc.stdout
    return [(int(m[1]), m[2], m[3], m[4]) for m in rows if m]


# What each index makes: the device EGL says the display is on, and GL_RENDERER.
CONTEXTS = """
import json, sys
from app.gl.context import create_context
made = []
for index in range(int(sys.argv[1])):
    gl = create_context("egl", index)
    made.append([gl.device, gl.renderer])
    gl.release()
print(json.dumps(made))
"""


def test_every_listed_device_makes_a_context_on_itself(two_devices: dict[str, str]) -> None:
    """``pbs devices`` lists indexes 0..n-1 (two here), each with a kind; a context made
    with each index is on that device (EGL says so) and reports the listed renderer."""
    listing = _listing(two_devices)
    assert [row[0] for row in listing] == list(range(len(listing)))
    assert len(listing) >= 2
    assert all(row[1] for row in listing)
    env = {**two_devices, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", CONTEXTS, str(len(listing))],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    made = json.loads(proc.stdout.splitlines()[-1])
    assert made == [[index, renderer] for index, _, _, renderer in listing]


def test_this_machines_devices_and_kinds() -> None:
    """The machine's own EGL (no vendor added): at least one device, and Mesa's software
    device says so in its kind."""
    listing = _listing()
    assert len(listing) == egl.device_count() >= 1
    for _, kind, _, renderer in listing:
        if "llvmpipe" in renderer or "softpipe" in renderer:
            assert kind.startswith("software (EGL_MESA_device_software)"), kind


def test_pbs_devices_imports_no_gl_stack() -> None:
    """``pbs devices`` is ctypes on libEGL: moderngl, glcontext and numpy stay out."""
    result = run_cli("devices")
    assert result["code"] == 0, result["stderr"]
    assert among(result["modules"], ("moderngl", "glcontext", "numpy", "app.render")) == []


def test_a_device_out_of_range_is_one_line_and_no_png(
    tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--device N`` and ``PBS_EGL_DEVICE=N`` with N = the number of devices: exit 2,
    one line naming the flag or variable and the count, nothing written; the flag wins
    over the variable; a variable that is no index is refused the same way."""
    count = egl.device_count()
    out = tmp_path / "x.png"
    render = ["render", "sec3_lambert", "-o", str(out), "--size", "16x9", "-q"]
    assert main([*render, "--device", str(count)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--device {count}: out of range" in err, err
    assert f"EGL enumerates {count} device" in err
    monkeypatch.setenv(egl.DEVICE_ENV, str(count))
    assert main(render) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{egl.DEVICE_ENV}={count}: out of range" in err, err
    assert not out.exists()
    assert main([*render, "--device", "0"]) == 0  # the flag over the variable
    assert out.is_file()
    monkeypatch.setenv(egl.DEVICE_ENV, "first")
    assert main(render) == 2
    assert f"{egl.DEVICE_ENV}=first" in capsys.readouterr().err
    jobs = tmp_path / "jobs.toml"
    jobs.write_text('scene = "sec3_lambert"\nsize = "16x16"\norbit = { frames = 2 }\n')
    monkeypatch.delenv(egl.DEVICE_ENV)
    folder = tmp_path / "frames"
    assert main(["batch", str(jobs), "-o", str(folder), "--devices", f"0,{count}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--devices {count}: out of range" in err, err
    assert not folder.exists()


def test_the_variable_and_the_flag_choose_the_device(
    two_devices: dict[str, str], tmp_path: Path
) -> None:
    """``PBS_EGL_DEVICE=1`` renders on device 1, ``--device 0`` over it on device 0
    (the render's line names the device EGL put the context on)."""
    render = ("render", "sec3_lambert", "-o", str(tmp_path / "x.png"), "--size", "16x9")
    env = {**two_devices, egl.DEVICE_ENV: "1"}
    for extra, device in (((), 1), (("--device", "0"), 0)):
        proc = _pbs(*render, *extra, env=env)
        assert proc.returncode == 0, proc.stderr
        assert ", egl (" in proc.stdout and f") on device {device}, " in proc.stdout, proc.stdout


def test_osmesa_ignores_a_device_in_one_note(tmp_path: Path) -> None:
    out = tmp_path / "x.png"
    proc = _pbs("render", "sec3_lambert", "-o", str(out), "--size", "16x9", "-q",
                "--backend", "osmesa", "--device", "0")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == "pbs: note: OSMesa has no devices: --device 0 is ignored\n"
    assert out.is_file()


def test_batch_workers_spread_over_the_devices(two_devices: dict[str, str], tmp_path: Path) -> None:
    """``--workers 2 --devices 0,1``: worker k on device k, as each job's manifest line
    says (every worker gets a first job, so both devices appear); the images equal one
    process's on device 0."""
    jobs = tmp_path / "jobs.toml"
    jobs.write_text('scene = "sec3_lambert"\nsize = "24x24"\norbit = { frames = 4 }\n')
    spread, one = tmp_path / "spread", tmp_path / "one"
    proc = _pbs("batch", str(jobs), "-o", str(spread), "--workers", "2", "--devices", "0,1",
                "-q", env=two_devices)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in (spread / "manifest.jsonl").read_text().splitlines()]
    assert {line["status"] for line in lines} == {"ok"}
    assert {line["device"] for line in lines} == {0, 1}
    proc = _pbs("batch", str(jobs), "-o", str(one), "--device", "1", "-q", env=two_devices)
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in (one / "manifest.jsonl").read_text().splitlines()]
    assert {line["device"] for line in lines} == {1}
    for k in range(4):
        name = f"frame-{k:04d}.png"
        assert (spread / name).read_bytes() == (one / name).read_bytes()


def test_gl_entry_points_come_from_egl(gl_egl: GLContext) -> None:
    """``gl_function`` on an EGL context is ``eglGetProcAddress``'s address, not the GLX
    libGL's export of the same name (a different stub, where libGL is installed)."""
    argtypes = [ctypes.c_uint, ctypes.c_uint, ctypes.c_int]
    for name in ("glTexParameteri", "glBindTexture", "glFlush"):
        function = gl_function(gl_egl.ctx, name, argtypes if name == "glTexParameteri" else [])
        address = ctypes.cast(function, ctypes.c_void_p).value
        assert address == egl.proc_address(name) != 0, name
        try:
            libgl = ctypes.CDLL("libGL.so.1")
        except OSError:
            continue
        assert address != ctypes.cast(getattr(libgl, name), ctypes.c_void_p).value, name


# A render, then the GL libraries the process has mapped.
MAPPED = """
import json, sys
from app.cli import main
assert main(["render", "sec3_lambert", "-o", sys.argv[1], "--size", "16x9", "-q",
             "--backend", "egl"]) == 0
maps = open("/proc/self/maps").read().splitlines()
print(json.dumps(sorted({line.rsplit("/", 1)[-1] for line in maps if "/lib" in line})))
"""


def test_an_egl_render_never_loads_the_glx_libgl(tmp_path: Path) -> None:
    """moderngl's own entry points come through EGL too: a whole EGL render maps neither
    libGL nor libGLX (a GLX-less server has neither)."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", MAPPED, str(tmp_path / "x.png")],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    mapped = json.loads(proc.stdout.splitlines()[-1])
    assert any(name.startswith("libEGL.so") for name in mapped), mapped
    assert not [n for n in mapped if n.startswith(("libGL.so", "libGLX.so"))], mapped


START_DEVICE_PROBE = """
import ctypes, json, threading
from app.gl import egl
lib = egl._library()
query = lib.eglQueryString
query.restype, query.argtypes = ctypes.c_char_p, [ctypes.c_void_p, ctypes.c_int]
platform_display = egl._extension(
    "eglGetPlatformDisplayEXT", egl._handle, [ctypes.c_uint, egl._handle, ctypes.POINTER(egl._int)]
)
display = platform_display(egl._EGL_PLATFORM_DEVICE_EXT, egl._device_handles()[0], None)
before = query(display, 0x3054)  # EGL_VERSION: NULL on a display not initialized
egl.start_device(None)
(started,) = [t for t in threading.enumerate() if t.name == "pbs-gl-device"]
started.join(60)
after = query(display, 0x3054)
from app.gl.context import create_context
gl = create_context("egl")
gl.ctx.clear(0.25, 0.5, 0.75, 1.0)
print(json.dumps({"before": before is not None, "after": (after or b"").decode(),
                  "device": gl.device, "renderer": gl.ctx.info["GL_RENDERER"]}))
"""


def test_start_device_initializes_the_display_the_context_is_made_on() -> None:
    """``egl.start_device`` (what ``pbs render`` starts while it imports and reads the
    scene) initializes device 0's display on a thread of its own: a fresh process's
    display answers EGL_VERSION only after it, and the context made afterwards is on that
    device and draws. An index EGL does not enumerate is refused by ``initialize_device``
    (``start_device`` reports nothing: the context's creation names it)."""
    env = {
        k: v for k, v in os.environ.items() if k not in (egl.DEVICE_ENV, "GLCONTEXT_DEVICE_INDEX")
    }
    proc = subprocess.run(
        [sys.executable, "-c", START_DEVICE_PROBE], cwd=REPO,
        env={**env, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.splitlines()[-1])
    assert not result["before"] and re.match(r"\d+\.\d+", result["after"]), result
    assert result["device"] == 0 and result["renderer"], result
    with pytest.raises(egl.EGLUnavailableError):
        egl.initialize_device(egl.device_count())
