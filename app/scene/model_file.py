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
  image-based light, one spot key light from above the camera's left shoulder with PCSS
  soft shadows (``key_light``) and a fill light two stops under it from the camera's
  right (``fill_light``), or the glTF file's own KHR_lights_punctual lights where
  it has any (``file_lights_note``), and the neutral tone map at the exposure metered for
  the asset (``metered_exposure``);
- the backdrop: under the studio, a light neutral grey of its own (``BACKDROP``, set in
  display values so that the asset's exposure does not move it: ``backdrop_radiance``),
  as product-shot and look-dev tools keep the backdrop apart from the lighting
  environment (KeyShot's backdrop colour, Blender's look-dev world opacity, f3d's
  background colour); a sky or an environment image the user names is shown itself,
  as the glTF Sample Viewer shows its environment.

The bounds come from the built parts, so the model's files are read twice (here and by
the renderer): the price of keeping app/scene free of the frame and render layers.

docs/scene-format.md ("A model file without a scene file") describes the same.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.reference.tonemap import post_process, srgb_decode
from app.scene.geometry import MeshPart, build_parts, keep_built
from app.scene.loader import LoadedScene, parse_scene
from app.scene.look import (
    ENVIRONMENTS,
    MODEL_SUFFIXES,
    VIEWS,
    Look,
    is_model_file,
    needs_defaults,
)
from app.scene.model import Light
from app.textures.environment import environment_map
from app.untrusted import RefusedError, files
from app.untrusted.budget import Budget
from app.untrusted.policy import InputPolicy

__all__ = [
    "ENVIRONMENTS",
    "MODEL_SUFFIXES",
    "VIEWS",
    "Look",
    "default_environment",
    "fill_light",
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
EXPOSURE = -2.4  # EV: the studio's room, boxes and key light on a light grey stay below white
KEY_INTENSITY = 1.5  # the key light's radiance scale (c_light)
KEY_DISTANCE = 4.0  # the key light's distance from the model's centre, in its radii
# The key light's shadow map: a power of two with at least this many texels a side per
# pixel of the image's longer side, within these bounds (the most: a scene light's default).
KEY_SHADOW_TEXELS_PER_PIXEL = 2
KEY_SHADOW_RESOLUTIONS = (512, 2048)
FILL_RATIO = 0.25  # the fill light's radiance scale to the key's: 2 stops under it
STUDIO_MEAN = 1.13  # the bundled studio's mean texel radiance
# Another environment (the sky, an image) with the key light: METER_EXPOSURE under a mean
# texel radiance of METER_MEAN or less, one stop less per doubling above it.
METER_EXPOSURE = -1.5  # EV
METER_MEAN = 0.37
STUDIO_TURN = 200.0  # the studio's rotation that puts its key box behind a +Z camera's left
# Reflected-light metering (``metered_exposure``): the asset's mean albedo against a mid
# reflectance, half of the difference in stops taken (a dark asset is lifted towards
# mid-grey but stays darker than a light one), within the bounds.
ALBEDO_REFERENCE = 0.5
ALBEDO_WEIGHT = 0.75
METER_BOUNDS = (-1.0, 1.5)  # EV about the incident exposure
BACKDROP = 0.78  # the studio backdrop's display value: sRGB-encoded, a light neutral grey


def _environment(look: Look, azimuth: float) -> dict[str, Any]:
    """The ``[environment]`` table of ``look.env``, turned with the camera: the studio
    lights the asset and stays out of sight (its own backdrop is ``BACKDROP``); a sky or
    an image is shown behind the asset too."""
    turn = (STUDIO_TURN + azimuth + 360.0) % 720.0 - 360.0
    if look.env == "studio":
        return {"source": "studio", "rotation": turn}
    if look.env in ENVIRONMENTS:
        return {"source": look.env, "background": True, "rotation": turn}
    return {"source": "image", "file": str(Path(look.env).resolve()), "background": True}


def default_environment(look: Look, azimuth: float) -> dict[str, Any]:
    """The default look's ``[environment]`` table."""
    return {"environment": _environment(look, azimuth)}


def key_shadow_resolution(pixels: tuple[int, int]) -> int:
    """The key light's shadow map side for an image of ``pixels`` (drawn, supersampling
    included): ``KEY_SHADOW_TEXELS_PER_PIXEL`` texels a side per pixel of its longer side,
    rounded up to a power of two, within ``KEY_SHADOW_RESOLUTIONS``. The key's cone is a
    little wider than the model and the camera frames the model, so the model spans most
    of both the map and the image: up to 512 pixels a side this keeps more than a texel
    a pixel across the model, more than the default 2048 map gives a 1280x720 image,
    without the 16 MiB of depth that map's render clears, draws and holds (the images at
    each side: docs/shadows.md, "The default look's key light")."""
    want = KEY_SHADOW_TEXELS_PER_PIXEL * max(pixels)
    least, most = KEY_SHADOW_RESOLUTIONS
    return min(max(1 << (want - 1).bit_length(), least), most)


def key_light(
    centre: np.ndarray, radius: float, azimuth: float, pixels: tuple[int, int]
) -> dict[str, Any]:
    """The default look's key light: a spot ``KEY_DISTANCE`` radii from the model's centre,
    above the camera's left shoulder (50 degrees to its left, 50 up), aimed at the centre,
    its cone a little wider than the model; its soft shadows by PCSS from a source a
    tenth of the model's radius, in a map sized for the image of ``pixels``
    (``key_shadow_resolution``). Its fall-off over the model keeps even a flat model
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
        "shadow_resolution": key_shadow_resolution(pixels),
        "shadow_light_radius": min(0.1 * radius, 10.0),
    }


def fill_light(azimuth: float) -> dict[str, Any]:
    """The default look's fill light: a directional light from the camera's right (60
    degrees to its right, 20 up), ``FILL_RATIO`` of the key's radiance, slightly cool and
    shadowless, so that the faces the key light leaves to the studio's room are
    lifted, as the key-and-fill pair the glTF Sample Viewer lights a file without lights
    with, and as a product photographer's fill card does."""
    az, el = math.radians(azimuth + 60.0), math.radians(20.0)
    towards = np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])
    return {
        "type": "directional",
        "direction": [float(-v) for v in towards],
        "color": [0.92, 0.96, 1.0],
        "intensity": KEY_INTENSITY * FILL_RATIO,
    }


def _surface_points(parts: list[MeshPart]) -> np.ndarray:
    """(N, 3) world-space points of every drawn part's surface (node transforms applied)."""
    points = [part.surface_points() @ part.model[:3, :3].T + part.model[:3, 3] for part in parts]
    return np.concatenate(points) if points else np.zeros((1, 3))


def _part_albedo(part: MeshPart) -> tuple[float, float]:
    """(luminance of the part's mean base colour, its world-space area): the base colour
    factor times its map (and vertex colours) at each triangle's centroid, weighted by the
    triangle's area (the map's UV transform left out: a meter's estimate)."""
    v = part.vertices.astype(np.float64)
    tri = part.indices.reshape(-1, 3)
    if len(tri) == 0:
        return 0.0, 0.0
    p = v[:, :3] @ part.model[:3, :3].T
    area = 0.5 * np.linalg.norm(
        np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]), axis=1
    )
    total = float(area.sum())
    if total <= 0.0 or not math.isfinite(total):
        return 0.0, 0.0
    layer = part.layers[0]
    colour = np.broadcast_to(np.array(layer.params.base_color, np.float64), (len(tri), 3))
    texture = layer.maps.get("base_color")
    if texture is not None:
        pixels = texture.pixels
        h, w = pixels.shape[:2]
        uv = v[tri, 6:8].mean(axis=1) * np.array(layer.uv_scale)
        col = (np.floor(np.mod(uv[:, 0], 1.0) * w).astype(np.int64)).clip(0, w - 1)
        row = (np.floor(np.mod(1.0 - uv[:, 1], 1.0) * h).astype(np.int64)).clip(0, h - 1)
        texels = pixels[row, col].reshape(len(tri), -1).astype(np.float64)
        texels = texels[:, :3] if texels.shape[1] >= 3 else texels[:, :1]  # grey (+ alpha)
        if pixels.dtype == np.uint8:
            texels /= 255.0
        colour = colour * (srgb_decode(texels) if texture.srgb else texels)
    if part.colors is not None:
        colour = colour * part.colors[tri, :3].astype(np.float64).mean(axis=1)
    luminance = colour @ np.array([0.2126, 0.7152, 0.0722])
    return float(luminance @ area) / total, total


def mean_albedo(parts: list[MeshPart]) -> float:
    """The area-weighted mean luminance of the base colour over every drawn surface: what
    a reflected-light meter reads of the asset under white light."""
    pairs = [_part_albedo(part) for part in parts]
    area = sum(a for _, a in pairs)
    return sum(x * a for x, a in pairs) / area if area > 0.0 else ALBEDO_REFERENCE


def metered_exposure(incident: float, albedo: float) -> float:
    """The exposure (EV) of the default look: the incident exposure (``exposure_for``, the
    light falling on the asset) moved by reflected-light metering of the asset's albedo,
    ``ALBEDO_WEIGHT`` of its stops from ``ALBEDO_REFERENCE`` within ``METER_BOUNDS``."""
    stops = ALBEDO_WEIGHT * math.log2(ALBEDO_REFERENCE / max(albedo, 1e-3))
    return incident + min(max(stops, METER_BOUNDS[0]), METER_BOUNDS[1])


def backdrop_radiance(exposure: float, tonemap: str) -> float:
    """The grey radiance that the post pass (``exposure`` EV, then ``tonemap``, then sRGB)
    shows as ``BACKDROP``: the backdrop stays one light grey whatever the asset's exposure.
    Bisection on the post pass's float64 twin (monotonic in the radiance)."""
    low, high = 0.0, 1.0
    while post_process(np.full(3, high), exposure, tonemap)[0] < BACKDROP and high < 1e9:
        high *= 2.0
    for _ in range(60):
        mid = 0.5 * (low + high)
        if post_process(np.full(3, mid), exposure, tonemap)[0] < BACKDROP:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


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


def _light_at(light: Light, centre: np.ndarray) -> float:
    """The luminance of ``light``'s c_light (RTR4 §9.4) arriving at ``centre``: inverse
    square for a point or spot light, nothing outside a spot's cone."""
    scale = light.intensity * float(np.array(light.color) @ np.array([0.2126, 0.7152, 0.0722]))
    if light.type == "directional" or light.position is None:
        return scale
    offset = centre - np.array(light.position)
    distance = max(float(np.linalg.norm(offset)), 1e-6)
    if light.type == "spot" and light.direction is not None:
        axis = np.array(light.direction) / max(float(np.linalg.norm(light.direction)), 1e-12)
        outer = light.outer_angle if light.outer_angle is not None else 45.0
        if float(axis @ offset) / distance < math.cos(math.radians(outer)):
            return 0.0
    return scale / (distance * distance)


def exposure_for(loaded: LoadedScene, centre: np.ndarray | None = None) -> float:
    """The default look's incident exposure (EV): ``EXPOSURE`` under the studio (less by
    how many stops a brighter ``intensity`` makes it); under another environment
    ``METER_EXPOSURE``, less by how many stops its mean radiance is brighter than
    ``METER_MEAN`` (the sky's is 4 stops brighter), so that a light grey model stays
    below white; where the scene's lights are the glTF file's instead of the key light,
    less (or more) by how much more (or less) light they bring to the model's ``centre``
    than the key light with the studio (a Lambertian surface's radiance per unit albedo:
    the environment's mean radiance plus each light's c_light / pi)."""
    env = loaded.scene.environment
    exposure = EXPOSURE
    if env is not None and env.source != "uniform":
        texels = environment_map(
            env.source,
            env.file,
            env.sun_direction,
            env.turbidity,
            scene_file=str(loaded.path),
            limits=loaded.policy.limits,
        )
        mean = float(np.mean(texels)) * env.intensity
        if env.source == "studio":
            exposure -= math.log2(max(mean, STUDIO_MEAN) / STUDIO_MEAN)
        else:
            exposure = METER_EXPOSURE - math.log2(max(mean, METER_MEAN) / METER_MEAN)
    if centre is not None:
        keyed = STUDIO_MEAN + KEY_INTENSITY / math.pi
        lit = STUDIO_MEAN + sum(_light_at(light, centre) for light in loaded.scene.lights) / math.pi
        exposure -= math.log2(lit / keyed)
    return min(max(exposure, -32.0), 32.0)


def framed(
    loaded: LoadedScene,
    look: Look,
    size: tuple[int, int],
    lit: bool = True,
    parts: list[MeshPart] | None = None,
) -> LoadedScene:
    """``loaded`` with a camera framing its drawn parts (``parts``: those already built);
    ``lit``: under the default look, whose exposure it takes (``metered_exposure``)."""
    parts = build_parts(loaded) if parts is None else parts
    camera = loaded.scene.camera.model_dump(exclude_unset=True)
    camera.update(framing_camera(_surface_points(parts), size, *look.angles()))
    return _lit(loaded, camera, parts, look, size) if lit else _with(loaded, camera=camera)


def _with(loaded: LoadedScene, **tables: Any) -> LoadedScene:
    """``loaded`` with some top-level tables replaced, validated again."""
    return loaded.with_scene(loaded.scene.model_validate({**_dumped(loaded), **tables}))


def _lit(
    loaded: LoadedScene,
    camera: dict[str, Any] | None,
    parts: list[MeshPart],
    look: Look,
    size: tuple[int, int] | None = None,
    file_lights: bool = False,
) -> LoadedScene:
    """``loaded`` with ``camera`` at the default look's metered exposure (None: the
    scene's camera and the exposure it gives, kept), the key and fill lights (unless
    ``file_lights``: the scene's lights are the glTF file's; the key's shadow map sized
    for the image of ``size``, default the scene's render size) and, under the studio,
    the backdrop for that exposure."""
    centre, radius = _sphere(_surface_points(parts))
    lights = _dumped(loaded).get("lights", [])
    if not file_lights:
        azimuth = look.angles()[0]
        key = key_light(centre, radius, azimuth, loaded.scene.render.drawn_size(size))
        lights = [*lights, key, fill_light(azimuth)]
    tables: dict[str, Any] = {"lights": lights}
    if camera is None:
        exposure = loaded.scene.camera.exposure
    else:
        keyed = _with(loaded, lights=lights)
        incident = exposure_for(keyed, centre if file_lights else None)
        exposure = metered_exposure(incident, mean_albedo(parts))
        tables["camera"] = {**camera, "exposure": exposure}
    if look.env == "studio" and "background" not in loaded.scene.model_fields_set:
        tone = loaded.scene.render.tonemap
        tables["background"] = [backdrop_radiance(exposure, tone)] * 3
    return _with(loaded, **tables)


def _dumped(loaded: LoadedScene) -> dict[str, Any]:
    return loaded.scene.model_dump(exclude_unset=True)


def model_scene(
    path: str | Path,
    policy: InputPolicy,
    look: Look = Look(),
    size: tuple[int, int] | None = None,
    still: bool = False,
) -> LoadedScene:
    """The validated scene that shows the model file ``path`` (refusals name the file).

    ``still``: the scene is rendered once from its framing camera (``pbs render``), so a
    glTF file's maps start at the finest mip level that camera can sample (its colour
    JPEGs DCT-scaled: app/scene/sampled_levels.py, GltfFile.uv_lods); a scene whose camera
    may move keeps every level."""
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
        "objects": [{"shape": "mesh", "file": path.name, "name": path.stem, **look.pose()}],
        **default_environment(look, azimuth),
    }
    if look.pose() and path.suffix.lower() not in (".glb", ".gltf"):
        option = f"--{next(iter(look.pose()))}"
        raise InputError(str(path), option, "animations and variants need a glTF file")
    if look.camera == "file":
        if path.suffix.lower() not in (".glb", ".gltf"):
            raise InputError(str(path), "--camera", "a camera from the file needs a glTF file")
        data["camera"] = {"from_file": 0}
    gltf = path.suffix.lower() in (".glb", ".gltf")
    if gltf:  # the file's KHR_lights_punctual lights, where it has any
        data["objects"][0]["import_lights"] = True
    try:
        loaded = parse_scene(data, path.resolve(), policy)
        file_lights = bool(loaded.scene.lights)
        if file_lights:
            _LOG.warning(
                "%s: lit by its own %d KHR_lights_punctual light(s) and the %s environment "
                "instead of the default key and fill lights",
                path,
                len(loaded.scene.lights),
                look.env if look.env in ENVIRONMENTS else "image",
            )
        budget = Budget(policy.limits)
        framed: list[dict] = []  # the camera the still's mip-level bound was taken for
        # the render table above samples once per pixel, at the centres the bound rasterises
        # (no supersample, jitter or msaa); a scene edited to another antialiasing or
        # supersample has another parts key, so its frame builds its own with every level
        if still and gltf and look.camera != "file":

            def framing(points: np.ndarray) -> tuple[dict, tuple[int, int]]:
                framed.append(framing_camera(points, (width, height), *look.angles()))
                return framed[-1], (width, height)

            loaded = replace(loaded, still_view=framing)
        parts = build_parts(loaded, budget)
        camera = loaded.scene.camera.model_dump(exclude_unset=True)
        if look.camera != "file":
            # the bound's own camera where one was taken (the same points, so the same
            # camera as framing the parts gives), so the levels skipped are the ones it saw
            camera.update(
                framed[-1]
                if framed
                else framing_camera(_surface_points(parts), (width, height), *look.angles())
            )
        lit = _lit(loaded, camera, parts, look, (width, height), file_lights)
        result = replace(lit, still_view=None)
        keep_built(result, parts, budget.spent, still=bool(framed))  # the frame takes them
        return result
    except InputError as exc:
        raise _as_model_error(exc, path) from None


def _as_model_error(exc: InputError, path: Path) -> InputError:
    """A refusal of the synthesized scene's model object as the model file's own: the
    file as given, no key of a scene file the user never wrote."""
    if exc.file != str(path.resolve()):
        return exc
    message = exc.message.removeprefix(f"{path.resolve()}: ").removeprefix(f"{path.name}: ")
    for key in ("animation", "time", "variant"):  # the option that asked for it
        if exc.key == f"objects[0].{key}":
            return InputError(str(path), f"--{key}", message.removeprefix(f"{path.resolve()}: "))
    if exc.key.startswith("objects[0]"):
        return InputError(str(path), "", message)
    if exc.key.startswith("camera"):  # camera = "file" where the file has none
        return InputError(str(path), "--camera", message)
    return exc


def with_defaults(
    loaded: LoadedScene, look: Look = Look(), size: tuple[int, int] | None = None
) -> LoadedScene:
    """A scene file that names a mesh but no camera (or no light) with the model file's
    defaults for what it lacks, and one note saying so; any other scene unchanged. The
    camera frames the meshes for ``size``, the image the scene is drawn at (``--size``;
    default the scene's render size), as a model file's does: framed for another aspect,
    the model would be cut at the image's edges."""
    camera, lighting = needs_defaults(loaded)
    if not (camera or lighting):
        return loaded
    data = _dumped(loaded)
    azimuth = look.angles()[0]
    if lighting:
        data.update(default_environment(look, azimuth))
    given = []
    if camera:
        given.append("a camera framing its objects")
    if lighting:
        given.append("the studio environment and a key light")
    _LOG.warning(
        "%s: gives no %s; using %s",
        loaded.path,
        " or ".join(w for w, g in (("camera", camera), ("light", lighting)) if g),
        " and ".join(given),
    )
    result = parse_scene(data, loaded.path, loaded.policy)
    budget = Budget(result.policy.limits)
    parts = build_parts(result, budget)
    if camera:
        size = size or (result.scene.render.width, result.scene.render.height)
        final = framed(result, look, size, lit=lighting, parts=parts)
    elif "exposure" not in result.scene.camera.model_fields_set:
        # the scene's camera, at the exposure metered for the default look's light: the
        # camera's exposure default (0 EV) is no choice of the scene's
        camera_table = result.scene.camera.model_dump(exclude_unset=True)
        final = _lit(result, camera_table, parts, look, size)
    else:  # the scene's camera and its exposure kept
        final = _lit(result, None, parts, look, size)
    keep_built(final, parts, budget.spent)  # the frame takes them, as a model file's
    return final


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
