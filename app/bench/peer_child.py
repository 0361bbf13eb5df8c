"""One peer renderer on a bench scene, in a child process: ``python -m app.bench.peer_child``.

The one protocol of the ``peers`` suite (app/bench/peers.py) for every peer (pygfx,
PyVista, pyrender): the first line on stdin is a request {"peer": name, "scene": scene
dict, "size": [w, h], "image": path}; the child builds the scene in that peer and draws
one warm-up frame, then writes one JSON line: {"ready": true, ...what it used} or
{"ok": false, "why": "..."} (not installed, no offscreen device...). After ``ready``, each
line ``frame`` on stdin renders one frame and reads its 8-bit image back into numpy,
answered with {"ms": t}; the line ``end`` writes the last image to ``image`` (.npy,
(H, W, 3) uint8, top row first) and the whole result {"ok": true, "ms": [...], ...}, and
the child exits. So the bench can alternate one frame of its own with one of each peer's,
and a change of the machine's load falls on all alike (timing.time_interleaved).

A separate process per peer: each makes its own GPU context (wgpu on Vulkan, VTK and
PyOpenGL on EGL) that must not meet the bench's moderngl one, and each is optional
(the ``peers`` extra): the bench records why when one cannot run.

Every peer is given the same triangles (app.scene.geometry.build_parts: an icosphere
sphere as pbs draws it with ``subdivisions``), per-vertex normals, the camera, the point
lights' positions, colours and intensities (inverse-square falloff, no range window), the
background colour and each material's base colour, metallic and roughness, in the colour
space the peer expects (linear base and light colours in all; the clear colour, which no
shader touches, display-encoded for VTK and pyrender). Antialiasing on: pygfx's FXAA
(``ppaa``, at pixel ratio 1: no supersampling), VTK's SSAA pass (its FXAA draws black
through EGL here), pyrender's 4x MSAA (built in). What each shades differently is in
docs/performance.md, "Peers".
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

# pbs's light intensity is c_light, the irradiance a light gives a surface facing it
# (RTR4 eq. 9.13: L = pi f c_light (n.l)); the peers' radiance is f I (n.l) / d^2 (glTF's
# punctual lights, three.js, VTK): their intensity is pi c_light.
PI_C_LIGHT = math.pi
Frame = Callable[[], np.ndarray]  # renders one frame, returns (H, W, 3) uint8, top row first


def _camera_basis(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, target, up of the scene's camera (float64)."""
    cam = scene.camera
    return (np.asarray(cam.position, np.float64), np.asarray(cam.target, np.float64),
            np.asarray(cam.up, np.float64))  # fmt: skip


def _meshes(loaded) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, object]]:
    """World-space (positions, normals, triangles, material) of every part."""
    from app.scene.geometry import build_parts

    out = []
    for part in build_parts(loaded):
        v, indices = part.triangles()
        model = np.asarray(part.model, np.float64)
        pos = v[:, 0:3] @ model[:3, :3].T + model[:3, 3]
        normal_m = np.linalg.inv(model[:3, :3]).T
        nrm = v[:, 3:6] @ normal_m.T
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        out.append((pos, nrm, np.asarray(indices).reshape(-1, 3), part.material))
    return out


def _point_lights(scene) -> list:
    lights = [light for light in scene.lights if light.type == "point"]
    if len(lights) != len(scene.lights):
        raise ValueError("the peers' scene has point lights only")
    return lights


# --- pygfx -----------------------------------------------------------------------------------


def _pygfx(loaded, size: tuple[int, int]) -> tuple[Frame, dict]:
    import pygfx as gfx
    from rendercanvas.offscreen import RenderCanvas

    scene_model = loaded.scene
    w, h = size
    canvas = RenderCanvas(size=(w, h), pixel_ratio=1)
    renderer = gfx.WgpuRenderer(canvas)
    renderer.pixel_ratio = 1  # its default 2 is 2x2 supersampling: FXAA alone here
    renderer.ppaa = "fxaa"
    scene = gfx.Scene()
    scene.add(gfx.Background.from_color(gfx.Color.from_physical(*scene_model.background)))
    for pos, nrm, tri, m in _meshes(loaded):
        geometry = gfx.Geometry(
            positions=pos.astype(np.float32), normals=nrm.astype(np.float32),
            indices=tri.astype(np.int32),
        )  # fmt: skip
        material = gfx.MeshStandardMaterial(
            color=gfx.Color.from_physical(*m.base_color),
            metalness=float(m.metallic), roughness=float(m.roughness),
        )  # fmt: skip
        scene.add(gfx.Mesh(geometry, material))
    for light in _point_lights(scene_model):
        node = gfx.PointLight(
            gfx.Color.from_physical(*light.color), intensity=PI_C_LIGHT * light.intensity,
            distance=0, decay=2,
        )  # fmt: skip
        node.local.position = tuple(float(x) for x in light.position)
        scene.add(node)
    position, target, up = _camera_basis(scene_model)
    aspect = w / h
    # pygfx's fov spans (1 + aspect) / 2 of the height: the one whose vertical angle is ours
    tan_half = math.tan(math.radians(scene_model.camera.fov_y) / 2) * (1 + aspect) / 2
    camera = gfx.PerspectiveCamera(math.degrees(2 * math.atan(tan_half)), aspect)
    camera.local.position = tuple(position)
    camera.world.reference_up = tuple(up)
    camera.look_at(tuple(target))
    camera.depth_range = (scene_model.camera.near, scene_model.camera.far)
    canvas.request_draw(lambda: renderer.render(scene, camera))

    def frame() -> np.ndarray:
        canvas.request_draw()
        return np.asarray(canvas.draw())[..., :3]

    import wgpu

    info = renderer.device.adapter.info
    return frame, {
        "version": gfx.__version__,
        "backend": f"wgpu {wgpu.__version__}, {info.get('backend_type')}: {info.get('device')}",
        # read back from the renderer: what it applies, not what was asked
        "antialiasing": f"{renderer.ppaa.upper()} (renderer.ppaa), pixel_ratio"
        f" {renderer.pixel_ratio:g}",
    }


# --- PyVista (VTK) ---------------------------------------------------------------------------


def _gamma(c) -> list[float]:
    """A linear colour as the display shows it (VTK's background: the clear colour)."""
    return [float(x) ** (1 / 2.2) for x in c]


def _linear(c) -> list[float]:
    """A linear colour, as VTK's physically based shader takes base and light colours
    (it encodes its output with a 2.2 gamma)."""
    return [float(x) for x in c]


def _pyvista(loaded, size: tuple[int, int]) -> tuple[Frame, dict]:
    import pyvista as pv
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    scene_model = loaded.scene
    w, h = size
    plotter = pv.Plotter(off_screen=True, window_size=(w, h), lighting="none")
    plotter.set_background(_gamma(scene_model.background))
    for pos, nrm, tri, m in _meshes(loaded):
        faces = np.hstack([np.full((len(tri), 1), 3), tri]).astype(np.int64).ravel()
        mesh = pv.PolyData(pos, faces)
        mesh.point_data["Normals"] = nrm
        mesh.point_data.active_normals_name = "Normals"
        plotter.add_mesh(
            mesh, color=_linear(m.base_color), pbr=True, metallic=float(m.metallic),
            roughness=float(m.roughness), smooth_shading=True,
        )  # fmt: skip
    for light in _point_lights(scene_model):
        node = pv.Light(
            position=tuple(light.position), color=tuple(_linear(light.color)),
            intensity=PI_C_LIGHT * light.intensity, positional=True, cone_angle=180,
            attenuation_values=(0.0, 0.0, 1.0), light_type="scene light",
        )  # fmt: skip
        plotter.add_light(node)
    position, target, up = _camera_basis(scene_model)
    plotter.camera.position = tuple(position)
    plotter.camera.focal_point = tuple(target)
    plotter.camera.up = tuple(up)
    plotter.camera.view_angle = float(scene_model.camera.fov_y)
    plotter.camera.clipping_range = (scene_model.camera.near, scene_model.camera.far)
    # Through EGL here VTK's FXAA (vtkRenderer.UseFXAA) draws a black image and its
    # multisampling changes no pixel, so its antialiasing is pyvista's SSAA render pass
    # (vtkSSAAPass), which is what pyvista's own "fxaa" falls back to under EGL.
    plotter.enable_anti_aliasing("ssaa")
    window = plotter.ren_win
    data = vtk.vtkUnsignedCharArray()

    def frame() -> np.ndarray:
        window.Render()
        window.GetPixelData(0, 0, w - 1, h - 1, 1, data, 0)
        return vtk_to_numpy(data).reshape(h, w, 3)[::-1]

    frame()  # the GL context exists once it has drawn: then it reports its renderer
    capabilities = window.ReportCapabilities().splitlines()
    gl = next((line for line in capabilities if "OpenGL renderer" in line), "?")
    return frame, {
        "version": f"pyvista {pv.__version__}, VTK {vtk.vtkVersion.GetVTKVersion()}",
        "backend": f"{type(window).__name__}, {gl.split(':', 1)[-1].strip()}",
        "antialiasing": "SSAA (vtkSSAAPass)",
    }


# --- pyrender --------------------------------------------------------------------------------


def _pyrender(loaded, size: tuple[int, int]) -> tuple[Frame, dict]:
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import pyrender

    from app.bench.pyrender_child import scene_of

    scene, dropped, _kinds, _camera = scene_of(loaded, size)
    renderer = pyrender.OffscreenRenderer(*size)

    def frame() -> np.ndarray:
        color, _depth = renderer.render(scene)  # colour and depth, both read back
        return color[..., :3]

    from OpenGL import GL

    frame()  # the context exists once it has drawn
    return frame, {
        "version": f"pyrender {pyrender.__version__}",
        "backend": f"PyOpenGL {os.environ['PYOPENGL_PLATFORM']}: "
        f"{GL.glGetString(GL.GL_RENDERER).decode()}",
        "antialiasing": "4x MSAA (built in)",
        "lights_dropped": dropped,
    }


PEERS: dict[str, Callable] = {"pygfx": _pygfx, "pyvista": _pyvista, "pyrender": _pyrender}
# What each peer needs importable (the suite's skip reason names the missing one).
PEER_MODULES = {"pygfx": "pygfx", "pyvista": "pyvista", "pyrender": "pyrender"}


def serve(request: dict, lines, say: Callable[[dict], None]) -> None:
    """The protocol (module docstring) on ``lines`` (stdin's), answers through ``say``."""
    from app.bench.scenes import load

    peer = request["peer"]
    size = (int(request["size"][0]), int(request["size"][1]))
    try:
        build = PEERS[peer]
        frame, info = build(load(request["scene"]), size)
        t0 = time.perf_counter()
        image = frame()  # warm-up: pipelines, uploads
        info["first_ms"] = (time.perf_counter() - t0) * 1e3
    except ImportError as exc:
        say({"ok": False, "why": f"{peer} is not installed ({exc}); pip install pbs-lab[peers]"})
        return
    except Exception as exc:
        say({"ok": False, "why": f"{peer} cannot render here: {type(exc).__name__}: {exc}"})
        return
    say({"ready": True, **info})
    times: list[float] = []
    for line in lines:
        if line.strip() != "frame":
            break
        t0 = time.perf_counter()
        image = frame()
        times.append((time.perf_counter() - t0) * 1e3)
        say({"ms": times[-1]})
    np.save(request["image"], np.ascontiguousarray(image, np.uint8))
    say({"ok": True, "ms": times, "ms_median": statistics.median(times) if times else None,
         **info})  # fmt: skip


# --- the parent's end ------------------------------------------------------------------------


def child_env() -> dict[str, str]:
    """A peer child's environment: this checkout's ``app``, PyOpenGL on EGL, VTK's EGL
    window (no X server is tried first)."""
    from app.bench.startup import repo_pythonpath

    env = dict(os.environ)
    env["PYTHONPATH"] = repo_pythonpath(env)
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    env.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    return env


class PeerChild:
    """A served peer (app/bench/peer_child.py): one frame per ``frame()``."""

    def __init__(self, peer: str, data: dict, size: tuple[int, int], image: Path) -> None:
        request = {"peer": peer, "scene": data, "size": list(size), "image": str(image)}
        self.peer = peer
        self.log = tempfile.TemporaryFile()  # noqa: SIM115 (the child's stderr; close())
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "app.bench.peer_child"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=self.log, text=True, env=child_env(),
        )  # fmt: skip
        self._send(json.dumps(request))
        self.info = self._answer()
        if not self.info.get("ready"):
            self.close()
            raise RuntimeError(self.info.get("why") or f"{peer} child did not start")

    def _send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def _answer(self) -> dict:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            if line.startswith("{"):
                return json.loads(line)
        code = self.proc.wait()
        self.log.seek(0)
        tail = (self.log.read().decode(errors="replace").strip().splitlines() or ["?"])[-1]
        return {"ok": False, "why": f"{self.peer} child ended (exit code {code}): {tail}"}

    def frame(self) -> None:
        """One frame of the peer, its 8-bit image read back into numpy."""
        self._send("frame")
        if "ms" not in self._answer():
            raise RuntimeError(f"{self.peer} child failed a frame")

    def finish(self) -> dict:
        """Its whole result, the last image written, the child ended."""
        self._send("end")
        result = self._answer()
        self.close()
        return result

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.log.close()


def main() -> int:
    request = json.loads(sys.stdin.readline())

    def say(answer: dict) -> None:
        print(json.dumps(answer), flush=True)

    serve(request, sys.stdin, say)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
