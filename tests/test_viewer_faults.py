"""The viewer survives what it is handed (docs/viewer.md, "When a file is bad"): under a
real glfw window on Xvfb, a hot reload of a scene whose mesh, texture or environment is
broken, a scene file swapped for a FIFO, a dropped OBJ with NaN coordinates, a dropped
FIFO or a glTF that declares 2^24 vertices each keep the last good state running, with one
line in the Problems panel and no freeze; and a window closed from outside (the window
manager's WM_DELETE_WINDOW, another client destroying it, the connection killed) ends
``pbs view`` with exit code 0 and nothing on stderr.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from app.resources import scenes_dir
from tests.test_viewer import SIZE, _wait_for, window_image

REPO = Path(__file__).resolve().parent.parent
MESH_SCENE = """\
[camera]
position = [0.0, 0.5, 3.0]
target = [0.0, 0.0, 0.0]

[[lights]]
type = "directional"
direction = [0.0, -0.5, -1.0]

[materials.m]
roughness = 0.5
{material}

[[objects]]
shape = "mesh"
file = "{mesh}"
material = "m"
{environment}"""
QUAD_OBJ = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
QUAD_OBJ += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"


def _hdr(width: int, height: int) -> bytes:
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode()
    return head + bytes([100, 110, 120, 128]) * (width * height)


def _png(path: Path) -> None:
    from PIL import Image

    Image.new("RGB", (8, 8), (200, 120, 40)).save(path)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "quad.obj").write_text(QUAD_OBJ, encoding="utf-8")
    _png(tmp_path / "tex.png")
    (tmp_path / "env.hdr").write_bytes(_hdr(16, 8))
    return tmp_path


def _scene(folder: Path, mesh: str = "quad.obj", material: str = "", environment: str = "") -> str:
    return MESH_SCENE.format(mesh=mesh, material=material, environment=environment)


@pytest.fixture
def viewer(xdisplay: str, folder: Path):
    from app.viewer.window import Viewer

    path = folder / "scene.toml"
    path.write_text(_scene(folder, material='base_color_map = "tex.png"'), encoding="utf-8")
    v = Viewer(path, SIZE, vsync=False)
    v.settle()
    yield v
    v.close()


def _rewrite(v, path: Path, text: str) -> None:
    """Write the scene file with a new time, and let the viewer's watch see it."""
    path.write_text(text, encoding="utf-8")
    stamp = time.time() + 1.0
    os.utime(path, (stamp, stamp))
    v.state.last_watch = 0.0


HUGE_GLTF = json.dumps({
    "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "accessors": [{"componentType": 5126, "count": 2**24, "type": "VEC3"}],
})  # fmt: skip
ENV = '[environment]\nsource = "image"\nfile = "{}"\n'
# case -> (a file to write beside the scene: name and bytes, or None; the scene's text)
BROKEN_RELOADS = {
    "missing-mesh": (None, dict(mesh="gone.obj")),
    "garbage-mesh": (("bad.obj", b"\xff\xfe\x00garbage"), dict(mesh="bad.obj")),
    "nan-mesh": (("nan.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), dict(mesh="nan.obj")),
    "huge-gltf": (("huge.gltf", HUGE_GLTF.encode()), dict(mesh="huge.gltf")),
    "garbage-texture": (("junk.png", b"not a png"), dict(material='base_color_map = "junk.png"')),
    "outside-texture": (None, dict(material='base_color_map = "/etc/hostname"')),
    "bad-environment": (
        ("bad.hdr", b"#?RADIANCE\n\nnonsense"), dict(environment=ENV.format("bad.hdr"))
    ),
    "huge-environment": (
        ("huge.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1000000 +X 2000000\n"),
        dict(environment=ENV.format("huge.hdr")),
    ),
    "deep-toml": (None, None),
}  # fmt: skip


def _broken(folder: Path, case: str) -> str:
    extra, keys = BROKEN_RELOADS[case]
    if extra is not None:
        (folder / extra[0]).write_bytes(extra[1])
    if keys is None:
        return "x = " + "[" * 5000 + "]" * 5000 + "\n"
    return _scene(folder, **keys)


@pytest.mark.parametrize("case", list(BROKEN_RELOADS))
def test_a_broken_reload_keeps_the_last_good_state(viewer, folder: Path, case: str) -> None:
    v = viewer
    path = v.document.path
    before = window_image(v)
    good = path.read_text(encoding="utf-8")
    renderer = v.renderer
    _rewrite(v, path, _broken(folder, case))
    _wait_for(v, lambda: bool(v.state.error))
    assert "\n" not in v.state.error and len(v.state.error) < 2000, v.state.error
    assert v.renderer is renderer, "the last good renderer was replaced"
    assert np.array_equal(window_image(v), before)
    assert v.document.scene.objects[0].file == "quad.obj"  # the good scene stays edited
    _rewrite(v, path, good.replace("roughness = 0.5", "roughness = 0.9"))
    _wait_for(v, lambda: not v.state.error)
    assert v.scene.materials["m"].roughness == 0.9


def test_a_scene_file_swapped_for_a_fifo_is_refused(viewer, folder: Path) -> None:
    v = viewer
    path = v.document.path
    before = window_image(v)
    path.unlink()
    os.mkfifo(path)
    v.state.last_watch = 0.0
    start = time.monotonic()
    _wait_for(v, lambda: bool(v.state.error), seconds=10)
    assert time.monotonic() - start < 10
    assert "not a regular file" in v.state.error
    assert np.array_equal(window_image(v), before)


@pytest.mark.parametrize(
    ("name", "make", "fragment"),
    [
        ("nan.obj", lambda p: p.write_text("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "NaN"),
        ("fifo.obj", os.mkfifo, "not a regular file"),
        ("fifo.toml", os.mkfifo, "not a regular file"),
        ("huge.gltf", lambda p: p.write_text(json.dumps({
            "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"componentType": 5126, "count": 2**24, "type": "VEC3"}]})),
         "past the limit"),
    ],
)  # fmt: skip
def test_a_bad_dropped_file_is_reported(viewer, folder: Path, name: str, make, fragment: str):
    v = viewer
    before = window_image(v)
    path = folder / name
    make(path)
    start = time.monotonic()
    assert not v.open_scene(path)
    assert time.monotonic() - start < 10
    assert fragment in v.state.error, v.state.error
    assert np.array_equal(window_image(v), before)


# --- closing the window from outside ------------------------------------------------------


def _send_wm_delete(window: int) -> None:
    """What a window manager's close button sends: a WM_PROTOCOLS ClientMessage holding
    WM_DELETE_WINDOW (ICCCM sec. 4.2.8.1)."""

    class ClientMessage(ctypes.Structure):
        _fields_ = [
            ("type", ctypes.c_int), ("serial", ctypes.c_ulong), ("send_event", ctypes.c_int),
            ("display", ctypes.c_void_p), ("window", ctypes.c_ulong),
            ("message_type", ctypes.c_ulong), ("format", ctypes.c_int),
            ("data", ctypes.c_long * 5), ("pad", ctypes.c_char * 96),
        ]  # fmt: skip

    x11 = ctypes.CDLL("libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XInternAtom.restype = ctypes.c_ulong
    x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    x11.XSendEvent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long,
                               ctypes.c_void_p]  # fmt: skip
    x11.XFlush.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    assert display, "cannot open the display"
    event = ClientMessage()
    event.type = 33  # ClientMessage
    event.window = window
    event.message_type = x11.XInternAtom(display, b"WM_PROTOCOLS", False)
    event.format = 32
    event.data[0] = x11.XInternAtom(display, b"WM_DELETE_WINDOW", False)
    x11.XSendEvent(display, window, False, 0, ctypes.byref(event))
    x11.XFlush(display)
    x11.XCloseDisplay(display)


def _window_of(pid: int, timeout: float = 60.0) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = subprocess.run(
            ["xdotool", "search", "--pid", str(pid), "--name", "pbs view"],
            capture_output=True, text=True,
        )  # fmt: skip
        ids = found.stdout.split()
        if ids:
            return int(ids[0])
        time.sleep(0.2)
    pytest.fail("the viewer's window did not appear")


@pytest.mark.parametrize("how", ["wm-delete", "destroyed", "connection-killed"])
def test_a_window_closed_from_outside_exits_0(xdisplay: str, how: str) -> None:
    if shutil.which("xdotool") is None:
        pytest.fail("xdotool is missing: run `bash scripts/dev.sh setup` (it installs it)")
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    scene = scenes_dir() / "sec1_both.toml"
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "view", str(scene), "--size", "160x90", "--no-vsync"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    window = _window_of(proc.pid)
    time.sleep(1.0)  # a few frames drawn
    if how == "wm-delete":
        _send_wm_delete(window)
    else:
        command = "windowclose" if how == "destroyed" else "windowkill"
        subprocess.run(["xdotool", command, str(window)], check=True)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert err.strip() == "", err
