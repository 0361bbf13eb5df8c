"""The whole pipeline against the float64 ray-caster: the GPU's linear HDR of a
scene of analytic primitives, compared on interior pixels with app/frame/raycast.py's
reference of the same scene (app/bench/metrics.py ``interior_errors``).

``five_spheres`` is the measuring scene: five spheres of the default model
(GGX, Smith height-correlated, Schlick, Lambert) under two directional lights, and two point
lights where asked; its two settings that matter, ``subdivisions`` (None: the analytic
sphere) and ``gbuffer`` (None: the default encoding), are arguments.
scripts/raycast_table.py prints docs/accuracy.md's table from it.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from app.bench.metrics import interior_errors
from app.frame.raycast import reference_scene
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene, parse_scene

# (base_color, metallic, roughness): a spread of roughness over dielectrics and metals,
# none below 0.3 so that no highlight is sharper than a few pixels at 640x360.
FIVE_SPHERES = [
    ((0.80, 0.20, 0.15), 0.0, 0.30),
    ((0.20, 0.60, 0.25), 0.0, 0.50),
    ((0.90, 0.90, 0.90), 0.0, 0.90),
    ((1.00, 0.78, 0.34), 1.0, 0.35),
    ((0.95, 0.64, 0.54), 1.0, 0.60),
]


def five_spheres(
    subdivisions: int | None = None, gbuffer: str | None = None, point_lights: bool = False
) -> LoadedScene:
    """Five unit-diameter spheres in a row, 1.2 m apart, seen from 6 m, lit by a warm key
    light from the upper left and a cool fill from the right (and, with ``point_lights``,
    two point lights with a range close in front of them); ``subdivisions`` None keeps the
    analytic sphere, ``gbuffer`` None the default encoding."""
    materials = {
        f"m{i}": {"base_color": list(c), "metallic": m, "roughness": r}
        for i, (c, m, r) in enumerate(FIVE_SPHERES)
    }
    objects = []
    for i in range(len(FIVE_SPHERES)):
        obj: dict = {
            "shape": "sphere",
            "radius": 0.5,
            "position": [1.2 * (i - 2), 0.0, 0.0],
            "material": f"m{i}",
        }
        if subdivisions is not None:
            obj["subdivisions"] = subdivisions
        objects.append(obj)
    data = {
        "background": [0.02, 0.02, 0.03],
        "render": {"width": 640, "height": 360},
        "camera": {"position": [0.0, 0.6, 6.0], "target": [0.0, 0.0, 0.0], "fov_y": 35.0},
        "materials": materials,
        "lights": [
            {"type": "directional", "direction": [0.5, -0.6, -0.62], "intensity": 3.0},
            {
                "type": "directional",
                "direction": [-0.8, -0.1, -0.6],
                "color": [0.6, 0.7, 1.0],
                "intensity": 1.0,
            },
        ],
        "objects": objects,
    }
    if gbuffer is not None:
        data["render"]["gbuffer"] = gbuffer
    if point_lights:
        data["lights"] += [
            {"type": "point", "position": [-1.4, 1.0, 1.4], "intensity": 6.0, "range": 6.0},
            {"type": "point", "position": [1.8, -0.4, 1.2], "color": [1.0, 0.85, 0.6],
             "intensity": 4.0, "range": 5.0},
        ]  # fmt: skip
    return parse_scene(data, Path("five_spheres.toml"))


def scene_with_spheres(
    path: Path, subdivisions: int | None = None, gbuffer: str | None = None
) -> LoadedScene:
    """A scene file with its analytic spheres drawn as icospheres of ``subdivisions``
    (None: kept analytic) and ``render.gbuffer`` set (None: the file's own): the same
    scene as the pipeline drew it with icospheres, or with another encoding."""
    data = tomllib.loads(Path(path).read_text())
    for obj in data.get("objects", []):
        if obj.get("shape") == "sphere" and subdivisions is not None:
            obj.setdefault("subdivisions", subdivisions)
    if gbuffer is not None:
        data.setdefault("render", {})["gbuffer"] = gbuffer
    return parse_scene(data, Path(path))


def gpu_hdr(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The renderer's linear HDR of ``loaded`` at ``size``, float64 (H, W, 3), and its
    coverage (H, W): the pixels some sample of whose G-buffer holds a surface (depth > 0)."""
    r = Renderer(gl, loaded, size)
    try:
        r.render()
        hdr = r.read_hdr().astype(np.float64)
        depth = r.read_gbuffer().depth
    finally:
        r.release()
    f = loaded.scene.render.supersample
    w, h = size
    covered = (depth > 0.0).reshape(h, f, w, f).any(axis=(1, 3))
    return hdr, covered


def raycast_errors(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int], flip: bool = True
) -> dict[str, float | None]:
    """``interior_errors`` of the renderer's HDR of ``loaded`` against the ray-caster's,
    on the pixels 2 px or more inside a silhouette (``interior_mask``), plus the share of
    pixels covered by one and not the other (``coverage_mismatch``)."""
    ref = reference_scene(loaded, size)
    hdr, covered = gpu_hdr(gl, loaded, size)
    cam, render = loaded.scene.camera, loaded.scene.render
    errors = interior_errors(hdr, ref.hdr, ref.interior(), cam.exposure, render.tonemap, flip)
    errors["coverage_mismatch"] = float(np.mean(covered != ref.covered))
    return errors
