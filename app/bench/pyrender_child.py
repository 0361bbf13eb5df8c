"""pyrender on the bench's scene, in a child process: ``python -m app.bench.pyrender_child``.

Reads a JSON request on stdin ({"scene": scene dict, "size": [w, h], "warmup": n,
"min_frames": n, "max_frames": n, "seconds": s}) and writes one JSON object on stdout:
{"ok": true, "ms": [...], ...} or {"ok": false, "why": "..."}.

An orbit request (the batch suite, app/bench/batch.py) is {"scene_file": path, "size":
[w, h], "cameras": [camera dicts as pbs batch's orbit jobs hold them], "out": folder}:
after one warm-up render of the scene's camera, each camera in turn is set, rendered,
read back and written as ``out/frame-NNNN.png`` with the project's PNG writer; ``ms``
holds each frame's time, all of that included.

The 35-sphere comparison (app/bench/spheres.py) and the peers suite serve pyrender frame
by frame through app/bench/peer_child.py, the one protocol of every peer, on this
module's ``scene_of``.

A separate process because pyrender makes its own EGL context current through PyOpenGL,
which must not meet the bench's moderngl contexts, and because pyrender is optional (the
``bench`` extra): the bench records why when it cannot run.

The scene is the renderer's own: the same triangles (app.scene.geometry.build_parts; an
analytic sphere as the 5,120-triangle icosphere it replaced), the
camera, and the point and spot lights with their colours and intensities. pyrender
shades them its own way (its metallic-roughness BRDF, lights without a range window, 4x
multisampling, sRGB output), so its image is not compared with the reference; pyrender
keeps at most 4 lights of each type per shader and drops the rest (the farthest, which
the result counts). Each timed ``render()`` returns the colour and depth images in
numpy, so the time includes that read-back.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import sys
import time


def _spot_pose(position: list[float], direction: list[float]):
    """A pose whose -Z axis is ``direction`` (pyrender's lights shine along -Z)."""
    import numpy as np

    z = -np.asarray(direction, np.float64)
    z /= np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = x, y, z, position
    return pose


def _loaded(request: dict):
    """The request's scene: a scene file (relative mesh paths resolve beside it) or dict."""
    if "scene_file" in request:
        from app.scene.loader import load_scene

        return load_scene(request["scene_file"])
    from app.bench.scenes import load

    return load(request["scene"])


def _build(request: dict):
    return scene_of(_loaded(request), request["size"])


def scene_of(loaded, size):
    """The pyrender scene of a loaded scene at ``size``: (scene, lights dropped, lights
    per type, camera node). Also the pyrender peer's (app/bench/peer_child.py)."""
    import numpy as np
    import pyrender

    from app.frame.camera import view_matrix
    from app.scene.geometry import build_parts

    scene_model = loaded.scene
    w, h = size
    from app.reference.tonemap import srgb_encode

    # glClearColor's value is the display's: the linear background encoded
    background = srgb_encode(np.asarray(scene_model.background, np.float64))
    scene = pyrender.Scene(ambient_light=[0.0, 0.0, 0.0], bg_color=[*background, 1.0])
    for part in build_parts(loaded):
        v, indices = part.triangles()  # an analytic sphere as the icosphere it replaced
        m = part.material
        material = pyrender.MetallicRoughnessMaterial(
            baseColorFactor=[*m.base_color, 1.0],
            metallicFactor=m.metallic,
            roughnessFactor=m.roughness,
        )
        primitive = pyrender.Primitive(
            positions=v[:, 0:3],
            normals=v[:, 3:6],
            indices=indices.reshape(-1, 3),
            material=material,
        )
        scene.add(pyrender.Mesh([primitive]), pose=part.model)
    kinds = {"point": 0, "spot": 0, "directional": 0}
    for light in scene_model.lights:
        # pbs's intensity is c_light, RTR4 eq. 9.13's L = pi f c_light (n.l); pyrender's
        # radiance is f I (n.l) (glTF's punctual lights): I = pi c_light
        intensity = math.pi * light.intensity
        kinds[light.type] += 1
        colour = list(light.color)
        if light.type == "point":
            pose = np.eye(4)
            pose[:3, 3] = light.position
            node = pyrender.PointLight(colour, intensity, light.effective_range)
        elif light.type == "spot":
            inner, outer = light.cone
            pose = _spot_pose(light.position, light.direction)
            node = pyrender.SpotLight(
                colour,
                intensity,
                light.effective_range,
                innerConeAngle=math.radians(inner),
                outerConeAngle=math.radians(outer),
            )
        else:
            pose = _spot_pose([0.0, 0.0, 0.0], light.direction)
            node = pyrender.DirectionalLight(colour, intensity)
        scene.add(node, pose=pose)
    cam = scene_model.camera
    camera = pyrender.PerspectiveCamera(
        yfov=math.radians(cam.fov_y), znear=cam.near, zfar=cam.far, aspectRatio=w / h
    )
    camera_node = scene.add(camera, pose=np.linalg.inv(view_matrix(cam)))
    limit = 4  # pyrender.constants.MAX_N_LIGHTS: per light type and shader
    dropped = sum(max(0, n - limit) for n in kinds.values())
    return scene, dropped, kinds, camera_node


def _orbit(renderer, scene, camera_node, request: dict):
    """Each of the request's cameras set, rendered, read back and written as a PNG: the
    ms of each frame, and the last colour image."""
    from pathlib import Path

    import numpy as np

    from app.frame.camera import view_matrix
    from app.output import write_png
    from app.scene.model import Camera

    out = Path(request["out"])
    times = []
    for k, data in enumerate(request["cameras"]):
        t0 = time.perf_counter()
        pose = np.linalg.inv(view_matrix(Camera.model_validate(data)))
        scene.set_pose(camera_node, pose)
        color, _depth = renderer.render(scene)
        write_png(out / f"frame-{k:04d}.png", np.ascontiguousarray(color[..., :3]))
        times.append((time.perf_counter() - t0) * 1e3)
    return times, color


def run(request: dict) -> dict:
    """Time pyrender on the request's scene; never raises."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    try:
        import pyrender
    except Exception as exc:  # not installed, or PyOpenGL cannot reach EGL
        return {"ok": False, "why": f"import pyrender failed: {type(exc).__name__}: {exc}"}
    try:
        scene, dropped, kinds, camera_node = _build(request)
        w, h = request["size"]
        renderer = pyrender.OffscreenRenderer(w, h)
    except Exception as exc:
        return {"ok": False, "why": f"pyrender setup failed: {type(exc).__name__}: {exc}"}
    try:
        from OpenGL import GL

        gl_renderer = GL.glGetString(GL.GL_RENDERER).decode()
        start = time.perf_counter()
        color, _depth = renderer.render(scene)  # warm-up: shader compiles, buffer uploads
        first_ms = (time.perf_counter() - start) * 1e3
        for _ in range(max(0, int(request.get("warmup", 1)) - 1)):
            renderer.render(scene)
        times: list[float] = []
        started = time.perf_counter()
        if "cameras" in request:
            times, color = _orbit(renderer, scene, camera_node, request)
        else:
            while len(times) < request["max_frames"] and (
                len(times) < request["min_frames"]
                or time.perf_counter() - started < request["seconds"]
            ):
                t0 = time.perf_counter()
                color, _depth = renderer.render(scene)
                times.append((time.perf_counter() - t0) * 1e3)
        return {
            "ok": True,
            "ms": times,
            "ms_median": statistics.median(times),
            "first_ms": first_ms,
            "version": getattr(pyrender, "__version__", "?"),
            "gl_renderer": gl_renderer,
            "platform": os.environ.get("PYOPENGL_PLATFORM"),
            "lights_dropped": dropped,
            "light_kinds": kinds,
            "image_mean": float(color.mean()),
        }
    except Exception as exc:
        return {"ok": False, "why": f"pyrender render failed: {type(exc).__name__}: {exc}"}
    finally:
        renderer.delete()


def main() -> int:
    request = json.loads(sys.stdin.readline())
    print(json.dumps(run(request)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
