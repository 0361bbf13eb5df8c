"""A model file (.glb, .gltf, .obj, .stl, .ply) rendered without a scene file, and the
default camera and lighting of a scene file that names meshes but gives neither.

The scene is written as data (a scene file's keys) and goes through the one validated
path (``parse_scene``): the model is ``[[objects]] file = "<its name>"``, its folder is the
confinement root and every budget applies, as for a scene file beside it. The camera is
then fitted to the model's world-space bounds, read from the parts the geometry loader
builds (every node transform applied), so it frames what will be drawn:

- it looks at the centre of the model's box from ``VIEWS[view]`` (azimuth about +Y from
  +Z towards +X, elevation above the horizon; a three-quarter view by default), as close
  as lets every surface point fall inside both fields of view with ``MARGIN`` to spare;
- near and far planes bracket the model's bounding sphere;
- the look: the bundled studio (or another environment; ``default_environment``) as
  image-based light and backdrop, one spot key light from above the camera's left
  shoulder with PCSS soft shadows (``key_light``), the neutral tone map at ``EXPOSURE``
  less the stops the environment is brighter than the studio (``exposure_for``).

The bounds come from the built parts, so the model's files are read twice (here and by
the renderer): the price of keeping app/scene free of the frame and render layers.

docs/scene-format.md ("A model file without a scene file") describes the same.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.scene.geometry import build_parts
from app.scene.loader import LoadedScene, parse_scene
from app.scene.look import ENVIRONMENTS, MODEL_SUFFIXES, VIEWS, Look, is_model_file
from app.textures.environment import environment_map
from app.untrusted import RefusedError, files
from app.untrusted.policy import InputPolicy

__all__ = [
    "ENVIRONMENTS",
    "MODEL_SUFFIXES",
    "VIEWS",
    "Look",
    "default_environment",
    "framed",
    "is_model_file",
    "key_light",
    "model_document",
    "model_scene",
    "needs_defaults",
    "with_defaults",
]

_LOG = logging.getLogger("pbs.scene")

FOV_Y = 35.0  # degrees
MARGIN = 1.08  # the bounding sphere's angular radius times this fits the narrower field
EXPOSURE = -1.5  # EV: the studio's boxes and the key light on a light grey stay below white
KEY_INTENSITY = 1.5  # the key light's radiance scale (c_light)
KEY_DISTANCE = 4.0  # the key light's distance from the model's centre, in its radii
STUDIO_MEAN = 0.37  # the bundled studio's mean texel radiance
STUDIO_TURN = 200.0  # the studio's rotation that puts its key box behind a +Z camera's left


def _environment(look: Look, azimuth: float) -> dict[str, Any]:
    """The ``[environment]`` table of ``look.env``, turned with the camera."""
    turn = (STUDIO_TURN + azimuth + 360.0) % 720.0 - 360.0
    if look.env in ENVIRONMENTS:
        return {"source": look.env, "background": True, "rotation": turn}
    return {"source": "image", "file": str(Path(look.env).resolve()), "background": True}


def default_environment(look: Look, azimuth: float) -> dict[str, Any]:
    """The default look's ``[environment]`` table."""
    return {"environment": _environment(look, azimuth)}


def key_light(centre: np.ndarray, radius: float, azimuth: float) -> dict[str, Any]:
    """The default look's key light: a spot ``KEY_DISTANCE`` radii from the model's centre,
    above the camera's left shoulder (50 degrees to its left, 50 up), aimed at the centre,
    its cone a little wider than the model; its soft shadows by PCSS from a source a
    tenth of the model's radius. Its fall-off over the model keeps even a flat model
    from looking flat-lit."""
    az, el = math.radians(azimuth - 50.0), math.radians(50.0)
    towards = np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])
    distance = KEY_DISTANCE * radius
    return {
        "type": "spot",
        "position": [float(v) for v in centre + distance * towards],
        "direction": [float(-v) for v in towards],
        "color": [1.0, 0.97, 0.92],
        "intensity": KEY_INTENSITY * distance * distance,
        "range": 2.0 * distance,
        "inner_angle": 12.0,
        "outer_angle": 24.0,
        "shadow": True,
        "shadow_filter": "pcss",
        "shadow_light_radius": min(0.1 * radius, 10.0),
    }


def _surface_points(loaded: LoadedScene) -> np.ndarray:
    """(N, 3) world-space points of every drawn part's surface (node transforms applied)."""
    points = [
        part.surface_points() @ part.model[:3, :3].T + part.model[:3, 3]
        for part in build_parts(loaded)
    ]
    return np.concatenate(points) if points else np.zeros((1, 3))


def _sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """(centre of the box of ``points``, distance from it to the farthest point)."""
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    return centre, max(float(np.max(np.linalg.norm(points - centre, axis=1))), 1e-3)


def framing_camera(
    points: np.ndarray, size: tuple[int, int], azimuth: float, elevation: float
) -> dict[str, Any]:
    """A ``[camera]`` table aimed at the centre of the world-space box of ``points`` from
    ``azimuth``/``elevation``, as close as lets every point fall inside both fields of view
    of an image of ``size`` with ``MARGIN`` to spare."""
    centre, radius = _sphere(points)
    az, el = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])
    up = np.array([0.0, 1.0, 0.0])
    if abs(elevation) > 89.0:  # looking straight down (or up): the model's -Z is up
        up = np.array([-math.sin(az), 0.0, -math.cos(az)])
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    rel = points - centre
    x, y, z = np.abs(rel @ right), np.abs(rel @ true_up), rel @ back
    tan_y = math.tan(math.radians(FOV_Y) / 2.0) / MARGIN
    tan_x = math.tan(math.radians(FOV_Y) / 2.0) * size[0] / size[1] / MARGIN
    # A point (x, y, z) in the view's axes lies inside the field when x / (d - z) <= tan_x.
    distance = float(max(np.max(z + x / tan_x), np.max(z + y / tan_y), 1e-3))
    return {
        "position": [float(v) for v in centre + distance * back],
        "target": [float(v) for v in centre],
        "up": [float(v) for v in up],
        "fov_y": FOV_Y,
        "near": max((distance - radius) * 0.5, radius * 1e-3),
        "far": distance + 2.0 * radius,
    }


def exposure_for(loaded: LoadedScene) -> float:
    """The default look's exposure (EV): ``EXPOSURE`` under an environment as bright as
    the studio or darker, less by how many stops its mean radiance is brighter (the sky's
    is 4 stops brighter), so that a light grey model stays below white."""
    env = loaded.scene.environment
    if env is None or env.source == "uniform":
        return EXPOSURE
    texels = environment_map(
        env.source,
        env.file,
        env.sun_direction,
        env.turbidity,
        scene_file=str(loaded.path),
        limits=loaded.policy.limits,
    )
    mean = float(np.mean(texels)) * env.intensity
    return max(EXPOSURE - math.log2(max(mean, STUDIO_MEAN) / STUDIO_MEAN), -32.0)


def framed(loaded: LoadedScene, look: Look, size: tuple[int, int], lit: bool = True) -> LoadedScene:
    """``loaded`` with a camera framing its drawn parts; ``lit``: under the default
    look, whose exposure it takes (``exposure_for``)."""
    points = _surface_points(loaded)
    camera = loaded.scene.camera.model_dump(exclude_unset=True)
    camera.update(framing_camera(points, size, *look.angles()))
    return _lit(loaded, camera, points, look) if lit else _with(loaded, camera=camera)


def _with(loaded: LoadedScene, **tables: Any) -> LoadedScene:
    """``loaded`` with some top-level tables replaced, validated again."""
    return loaded.with_scene(loaded.scene.model_validate({**_dumped(loaded), **tables}))


def _lit(
    loaded: LoadedScene, camera: dict[str, Any], points: np.ndarray, look: Look
) -> LoadedScene:
    """``loaded`` with ``camera`` at the default look's exposure and the key light."""
    camera = {**camera, "exposure": exposure_for(loaded)}
    key = key_light(*_sphere(points), look.angles()[0])
    return _with(loaded, camera=camera, lights=[*_dumped(loaded).get("lights", []), key])


def _dumped(loaded: LoadedScene) -> dict[str, Any]:
    return loaded.scene.model_dump(exclude_unset=True)


def model_scene(
    path: str | Path,
    policy: InputPolicy,
    look: Look = Look(),
    size: tuple[int, int] | None = None,
) -> LoadedScene:
    """The validated scene that shows the model file ``path`` (refusals name the file)."""
    path = Path(path)
    if not is_model_file(path):
        raise InputError(str(path), "", f"not a model file (known: {', '.join(MODEL_SUFFIXES)})")
    try:
        files.check_readable(path, policy.limits.max_file_bytes)
    except RefusedError as exc:
        raise InputError(str(path), "", str(exc).removeprefix(f"{path}: ")) from None
    width, height = size or (1280, 720)
    azimuth = look.angles()[0]
    data: dict[str, Any] = {
        "render": {"width": width, "height": height, "tonemap": "neutral"},
        "objects": [{"shape": "mesh", "file": path.name, "name": path.stem}],
        **default_environment(look, azimuth),
    }
    if look.camera == "file":
        if path.suffix.lower() not in (".glb", ".gltf"):
            raise InputError(str(path), "--camera", "a camera from the file needs a glTF file")
        data["camera"] = {"from_file": 0}
    try:
        loaded = parse_scene(data, path.resolve(), policy)
        if look.camera == "file":
            return _file_camera(loaded, look)
        return framed(loaded, look, (width, height))
    except InputError as exc:
        raise _as_model_error(exc, path) from None


def _as_model_error(exc: InputError, path: Path) -> InputError:
    """A refusal of the synthesized scene's model object as the model file's own: the
    file as given, no key of a scene file the user never wrote."""
    if exc.file != str(path.resolve()):
        return exc
    message = exc.message.removeprefix(f"{path.resolve()}: ").removeprefix(f"{path.name}: ")
    if exc.key.startswith("objects[0]"):
        return InputError(str(path), "", message)
    if exc.key.startswith("camera"):  # camera = "file" where the file has none
        return InputError(str(path), "--camera", message)
    return exc


def _file_camera(loaded: LoadedScene, look: Look) -> LoadedScene:
    """The scene with the glTF file's camera, exposed for the default look."""
    camera = loaded.scene.camera.model_dump(exclude_unset=True)
    return _lit(loaded, camera, _surface_points(loaded), look)


def needs_defaults(loaded: LoadedScene) -> tuple[bool, bool]:
    """(camera, lighting): whether a scene file that names a mesh file gives no camera,
    and whether it gives no light, environment or imported lights."""
    scene = loaded.scene
    if not any(obj.file is not None for obj in scene.objects):
        return False, False
    camera = "camera" not in scene.model_fields_set
    lighting = (
        not scene.lights
        and scene.environment is None
        and not any(obj.import_lights for obj in scene.objects)
    )
    return camera, lighting


def with_defaults(loaded: LoadedScene, look: Look = Look()) -> LoadedScene:
    """A scene file that names a mesh but no camera (or no light) with the model file's
    defaults for what it lacks, and one note saying so; any other scene unchanged."""
    camera, lighting = needs_defaults(loaded)
    if not (camera or lighting):
        return loaded
    data = _dumped(loaded)
    azimuth = look.angles()[0]
    if lighting:
        data.update(default_environment(look, azimuth))
    given = []
    if camera:
        given.append("a camera framing its meshes")
    if lighting:
        given.append("the studio environment and a key light")
    _LOG.warning(
        "%s: gives no %s; using %s",
        loaded.path,
        " or ".join(w for w, g in (("camera", camera), ("light", lighting)) if g),
        " and ".join(given),
    )
    result = parse_scene(data, loaded.path, loaded.policy)
    if camera:
        size = (result.scene.render.width, result.scene.render.height)
        return framed(result, look, size, lit=lighting)
    key = key_light(*_sphere(_surface_points(result)), look.angles()[0])
    return _with(result, lights=[key])  # the scene's own camera and exposure kept


def model_document(
    path: str | Path, policy: InputPolicy, look: Look = Look(), size: tuple[int, int] | None = None
) -> tuple[Path, dict[str, Any]]:
    """The scene of the model file ``path`` as the data a scene file would hold, and the
    scene file it is saved as (beside the model, a name no file has yet): what the viewer
    opens for ``pbs view MODEL``."""
    data = _dumped(model_scene(path, policy, look, size))
    path = Path(path).resolve()
    target = path.with_suffix(".toml")
    n = 2
    while target.exists():
        target = path.with_name(f"{path.stem}-{n}.toml")
        n += 1
    return target, data
