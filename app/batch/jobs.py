"""The job file of ``pbs batch``: read, validated, and expanded into one ``Job`` per image.

A job file is TOML (or JSON, by its ``.json`` suffix) with exactly one of three tables or
keys (docs/batch.md)::

    scene = "showcase"                      # orbit and sweep: the scene (file or bundled name)
    size = "512x512"                        # optional: every image's size (default: the scene's)
    orbit = { frames = 100, degrees = 360 } # N frames turning the camera about its up axis
    # sweep = { key = "materials.gold.roughness", values = [0.1, 0.5] }
    # sweep = { key = "materials.gold.roughness", start = 0.1, stop = 0.9, count = 9 }
    # scenes = ["a.toml", "b.glb"]          # a list of scene or model files (no top-level scene)
    look = { view = "front", env = "sky" }   # optional: how model files are shown

A ``scene`` or ``scenes`` entry may name a model file (.glb, .gltf, .obj, .stl, .ply):
it renders as ``pbs render MODEL`` shows it (app/scene/model_file.py: framed for the
image's size, the default look), and ``look`` takes the CLI's look options (``view``,
``azimuth``, ``elevation``, ``camera``, ``env``: studio, sky or an .hdr/.exr image
relative to the job file).

Everything the job file says is checked here, before any GL work, and a problem is an
``InputError`` naming the job file and the key (the CLI's exit 2). The orbit's cameras and
the sweep's scenes are validated here too, so a sweep value the scene refuses is bad job
file input, not a failed job. The files of a ``scenes`` list are only resolved: one that
is missing or broken fails its own job (its manifest line), never the others.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import KW_ONLY, dataclass, field
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.resources import scenes_dir
from app.scene.edits import KeyPathError, edited, parse_key
from app.scene.loader import LoadedScene, load_scene, read_text
from app.scene.look import VIEWS, Look, is_model_file
from app.scene.model import Camera
from app.untrusted import RefusedError, files
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy
from app.untrusted.structured import parse_json, parse_toml

KINDS = ("orbit", "sweep", "scenes")
_TOP_KEYS = {"scene", "size", "background", "look", *KINDS}
BACKGROUNDS = ("opaque", "transparent")  # render.background's values
_LOOK_KEYS = {"view", "azimuth", "elevation", "camera", "env", "animation", "time", "variant"}
MAX_JOBS = 100_000  # a typo in a count must not plan a billion images
MODEL_SIZE = (1280, 720)  # a model file's image without a size (as pbs render MODEL)


@dataclass(frozen=True)
class Job:
    """One image: what to render and where (picklable: it crosses to worker processes).

    ``scene``: the scene file or model file. ``look``: how a model file (or a scene file
    without camera or lights) is shown, None for the defaults. ``camera``: an orbit
    frame's camera (a ``Camera`` dump), or None. ``key``/``value``: a sweep step's key
    path and value, or None. ``size``: the image's (width, height), or None for the
    scene's own. ``expected``: the size the PNG
    will have, where it is known before rendering (resume checks outputs against it).
    """

    id: str
    output: str
    scene: str
    size: tuple[int, int] | None = None
    camera: dict | None = None
    key: str | None = None
    value: object = None
    expected: tuple[int, int] | None = None
    _: KW_ONLY  # the rest by name: two of them are optional str-like values, easily swapped
    policy: InputPolicy = field(default=DEFAULT_POLICY, compare=False)
    background: str | None = None  # render.background over the scene's (RGBA: transparent)
    look: Look | None = None


@dataclass(frozen=True)
class Plan:
    """A validated job file: its kind and jobs in output order."""

    file: str
    kind: str
    jobs: list[Job]


def _bad(file: Path, key: str, message: str) -> InputError:
    return InputError(str(file), key, message)


def read_job_file(path: str | Path, policy: InputPolicy = DEFAULT_POLICY) -> dict:
    """The job file's data: TOML, or JSON where the name ends in ``.json`` (nesting
    bounded, app/untrusted/structured.py)."""
    path = Path(path)
    text = read_text(path, "job file", policy)
    depth = policy.limits.max_nesting
    try:
        data = (
            parse_json(text, depth) if path.suffix.lower() == ".json" else parse_toml(text, depth)
        )
    except RefusedError as exc:
        raise _bad(path, "", str(exc)) from None
    if not isinstance(data, dict):
        raise _bad(path, "", "expected a table (a JSON object) at the top")
    return data


def _size(file: Path, value: object) -> tuple[int, int]:
    """``"WxH"`` or ``[W, H]``, each within 1..16384 (the CLI's --size range)."""
    if isinstance(value, str) and (m := re.fullmatch(r"(\d+)[xX](\d+)", value)):
        value = [int(m.group(1)), int(m.group(2))]
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(type(v) is int and 1 <= v <= 16384 for v in value)
    ):
        return (value[0], value[1])
    raise _bad(file, "size", f'expected "WIDTHxHEIGHT" or [W, H] within 1..16384, got {value!r}')


def _number(file: Path, key: str, value: object, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not low <= value <= high:
        raise _bad(file, key, f"expected a number within {low:g}..{high:g}, got {value!r}")
    return float(value)


def _count(file: Path, key: str, value: object) -> int:
    if type(value) is not int or not 1 <= value <= MAX_JOBS:
        raise _bad(file, key, f"expected an integer within 1..{MAX_JOBS}, got {value!r}")
    return value


def _table(file: Path, key: str, value: object, allowed: set[str]) -> dict:
    if not isinstance(value, dict):
        raise _bad(file, key, f"expected a table, got {value!r}")
    for name in value:
        if name not in allowed:
            raise _bad(file, f"{key}.{name}", f"unknown key (known: {', '.join(sorted(allowed))})")
    return value


def load_source(
    path: str | Path, policy: InputPolicy, look: Look | None, size: tuple[int, int] | None
) -> LoadedScene:
    """The scene a job renders: a model file framed (for ``size``) and lit by the default
    look, or a scene file, given the defaults it lacks (camera, lights) as ``pbs render``
    gives them; ``look`` on a scene file that has both is refused (app/scene/sources.py).
    The model-file code (geometry, trimesh, decoders) is imported here, not with the job
    file's checks, so a bad job file is refused without it (docs/architecture.md)."""
    from app.scene.model_file import model_scene, needs_defaults, with_defaults

    if is_model_file(path):
        return model_scene(path, policy, look or Look(), size)
    if look is not None and look.pose():
        raise InputError(
            str(path),
            "",
            "a look's animation, time or variant applies only to a model file; a scene "
            "file poses a glTF object with its own keys",
        )
    loaded = load_scene(path, policy)
    if look is not None and look != Look() and needs_defaults(loaded) == (False, False):
        raise InputError(
            str(path),
            "",
            "gives its own camera and lights: a look applies only to a model file or a "
            "scene file that gives neither",
        )
    return with_defaults(loaded, look or Look(), size)


def _look(file: Path, data: dict, policy: InputPolicy) -> tuple[Look | None, InputPolicy]:
    """The job file's ``look`` table as a ``Look`` (None without one), and the policy
    that lets the scene read its environment image (a file inside the job file's folder)."""
    if "look" not in data:
        return None, policy
    spec = _table(file, "look", data["look"], _LOOK_KEYS)
    view = spec.get("view", "three-quarter")
    if view not in VIEWS:
        raise _bad(file, "look.view", f"expected one of {', '.join(VIEWS)}, got {view!r}")
    angles = {}
    for name, bound in (("azimuth", 360.0), ("elevation", 90.0)):
        if name in spec:
            angles[name] = _number(file, f"look.{name}", spec[name], -bound, bound)
    camera = spec.get("camera", "auto")
    if camera not in ("auto", "file"):
        raise _bad(file, "look.camera", f'expected "auto" or "file", got {camera!r}')
    env = spec.get("env", "studio")
    if not isinstance(env, str) or not env:
        raise _bad(file, "look.env", f"expected studio, sky or an .hdr/.exr file, got {env!r}")
    if env not in ("studio", "sky"):
        if Path(env).suffix.lower() not in (".hdr", ".exr"):
            raise _bad(file, "look.env", f"expected studio, sky or an .hdr/.exr file, got {env!r}")
        try:
            image = files.confine(env, file, policy)
        except RefusedError as exc:
            raise _bad(file, "look.env", str(exc)) from None
        if not image.is_file():
            raise _bad(file, "look.env", f"no such file: {image}")
        env = str(image)
        policy = InputPolicy(allowed=(*policy.allowed, image.parent), limits=policy.limits)
    pose = _pose(file, spec)
    look = Look(view, angles.get("azimuth"), angles.get("elevation"), camera, env, **pose)
    return look, policy


def _pose(file: Path, spec: dict) -> dict:
    """The ``look`` table's glTF pose: ``animation`` (a name, or an index), ``time``
    (seconds) and ``variant`` (a name), as ``Look`` fields."""
    pose: dict = {}
    if "animation" in spec:
        value = spec["animation"]
        if type(value) is int and value >= 0:
            value = str(value)
        if not isinstance(value, str) or not value:
            raise _bad(file, "look.animation", f"expected a name or an index, got {value!r}")
        pose["animation"] = value
    if "time" in spec:
        pose["time"] = _number(file, "look.time", spec["time"], -1e9, 1e9)
    if "variant" in spec:
        if not isinstance(spec["variant"], str) or not spec["variant"]:
            raise _bad(file, "look.variant", f"expected a variant's name, got {spec['variant']!r}")
        pose["variant"] = spec["variant"]
    return pose


def resolve_scene(name: str, job_file: Path, policy: InputPolicy, key: str) -> Path:
    """A scene named in a job file: a bundled scene's name (``showcase``), as ``pbs
    render`` takes it, or a path relative to the job file's folder, confined to the
    folders ``policy`` allows (an ``InputError`` naming ``key`` otherwise)."""
    if not Path(name).suffix and "/" not in name:
        bundled = scenes_dir() / f"{name}.toml"
        if bundled.is_file() and not (job_file.parent / name).exists():
            return bundled
    try:
        return files.confine(name, job_file, policy)
    except RefusedError as exc:
        raise _bad(job_file, key, str(exc)) from None


def _load_base(
    file: Path, data: dict, policy: InputPolicy, look: Look | None, size: tuple[int, int] | None
) -> LoadedScene:
    if "scene" not in data:
        raise _bad(file, "scene", "missing: the scene file that the orbit or sweep renders")
    if not isinstance(data["scene"], str) or not data["scene"]:
        raise _bad(file, "scene", f"expected a scene file's path, got {data['scene']!r}")
    path = resolve_scene(data["scene"], file, policy, "scene")
    if not path.is_file():
        raise _bad(file, "scene", f"no such scene file: {path}")
    return load_source(path, policy, look, size)


def _image_size(loaded: LoadedScene, size: tuple[int, int] | None) -> tuple[int, int]:
    render = loaded.scene.render
    return size if size is not None else (render.width, render.height)


def orbit_cameras(camera: Camera, frames: int, degrees: float) -> list[Camera]:
    """``frames`` cameras turned about the axis through the target along the camera's up
    vector, by ``degrees * k / frames`` for k = 0..frames-1 (frame 0 is ``camera``
    itself, bit for bit). Rodrigues' rotation in float64; the lens and up are kept."""
    target = np.asarray(camera.target, np.float64)
    offset = np.asarray(camera.position, np.float64) - target
    axis = np.asarray(camera.up, np.float64)
    axis /= np.linalg.norm(axis)
    cameras = [camera]
    for k in range(1, frames):
        angle = math.radians(degrees * k / frames)
        c, s = math.cos(angle), math.sin(angle)
        rotated = offset * c + np.cross(axis, offset) * s + axis * float(axis @ offset) * (1.0 - c)
        position = [float(x) for x in target + rotated]
        cameras.append(camera.model_copy(update={"position": position}))
    return cameras


def _orbit(
    file: Path,
    data: dict,
    out: Path,
    size: tuple[int, int] | None,
    policy: InputPolicy,
    look: Look | None,
) -> list[Job]:
    spec = _table(file, "orbit", data["orbit"], {"frames", "degrees"})
    if "frames" not in spec:
        raise _bad(file, "orbit.frames", "missing: the number of frames")
    frames = _count(file, "orbit.frames", spec["frames"])
    degrees = _number(file, "orbit.degrees", spec.get("degrees", 360.0), -36000.0, 36000.0)
    loaded = _load_base(file, data, policy, look, size)
    expected = _image_size(loaded, size)
    jobs = []
    for k, camera in enumerate(orbit_cameras(loaded.scene.camera, frames, degrees)):
        name = f"frame-{k:04d}"
        output = str(out / f"{name}.png")
        jobs.append(Job(name, output, str(loaded.path), size, camera.model_dump(),
                        expected=expected, policy=policy, look=look))  # fmt: skip
    return jobs


def _sweep_values(file: Path, spec: dict) -> list[object]:
    if "values" in spec:
        if {"start", "stop", "count"} & set(spec):
            raise _bad(file, "sweep.values", "give either values or start, stop and count")
        values = spec["values"]
        if not isinstance(values, list) or not 1 <= len(values) <= MAX_JOBS:
            raise _bad(file, "sweep.values", f"expected a list of 1..{MAX_JOBS} values")
        return values
    for name in ("start", "stop", "count"):
        if name not in spec:
            why = "missing: a sweep needs values, or start, stop and count"
            raise _bad(file, f"sweep.{name}", why)
    start = _number(file, "sweep.start", spec["start"], -1e30, 1e30)
    stop = _number(file, "sweep.stop", spec["stop"], -1e30, 1e30)
    count = _count(file, "sweep.count", spec["count"])
    # Inclusive of both ends, as numpy's linspace; float() keeps TOML's own float type.
    return [float(v) for v in np.linspace(start, stop, count)]


def _sweep(
    file: Path,
    data: dict,
    out: Path,
    size: tuple[int, int] | None,
    policy: InputPolicy,
    look: Look | None,
) -> list[Job]:
    spec = _table(file, "sweep", data["sweep"], {"key", "values", "start", "stop", "count"})
    if not isinstance(spec.get("key"), str):
        raise _bad(file, "sweep.key", "missing or not a string: the scene key to sweep")
    origin = f"{file}: sweep.key"
    path = parse_key(spec["key"], str(file))
    values = _sweep_values(file, spec)
    loaded = _load_base(file, data, policy, look, size)
    jobs = []
    for i, value in enumerate(values):
        try:
            swept = edited(loaded, [(path, value)], origin)
        except KeyPathError:
            raise
        except InputError as exc:
            raise _bad(file, f"sweep.values[{i}]", f"{spec['key']} = {value!r}: {exc}") from None
        name = f"sweep-{i:04d}"
        output = str(out / f"{name}.png")
        expected = _image_size(swept, size)
        job = Job(name, output, str(loaded.path), size, None, spec["key"], value, expected,
                  policy=policy, look=look)  # fmt: skip
        jobs.append(job)
    return jobs


def _scenes(
    file: Path,
    data: dict,
    out: Path,
    size: tuple[int, int] | None,
    policy: InputPolicy,
    look: Look | None,
) -> list[Job]:
    names = data["scenes"]
    if "scene" in data:
        raise _bad(file, "scene", "a scenes list names its own files: give no scene")
    if not isinstance(names, list) or not 1 <= len(names) <= MAX_JOBS:
        raise _bad(file, "scenes", f"expected a list of 1..{MAX_JOBS} scene files")
    jobs = []
    for i, name in enumerate(names):
        if not isinstance(name, str) or not name:
            raise _bad(file, f"scenes[{i}]", f"expected a scene file's path, got {name!r}")
        path = resolve_scene(name, file, policy, f"scenes[{i}]")
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", path.stem)
        job_id = f"{i:04d}-{stem}"
        try:  # the size resume checks against; a broken file fails its own job later
            expected = _image_size(load_scene(path, policy), size)
        except InputError:
            expected = None
        if is_model_file(path):  # framed for the size it renders at
            expected = size or MODEL_SIZE
        output = str(out / f"{job_id}.png")
        jobs.append(Job(job_id, output, str(path), size=size, expected=expected, policy=policy,
                        look=look))  # fmt: skip
    return jobs


def plan_jobs(path: str | Path, out: str | Path, policy: InputPolicy = DEFAULT_POLICY) -> Plan:
    """The job file at ``path`` validated and expanded into jobs writing under ``out``;
    the scenes it names, and the files they name, are read under ``policy``."""
    file = Path(path)
    data = read_job_file(file, policy)
    for key in data:
        if key not in _TOP_KEYS:
            raise _bad(file, key, f"unknown key (known: {', '.join(sorted(_TOP_KEYS))})")
    kinds = [k for k in KINDS if k in data]
    if len(kinds) != 1:
        raise _bad(file, "", f"expected exactly one of {', '.join(KINDS)}, found {len(kinds)}")
    size = _size(file, data["size"]) if "size" in data else None
    background = data.get("background")
    if background is not None and background not in BACKGROUNDS:
        raise _bad(
            file, "background", f"expected one of {', '.join(BACKGROUNDS)}, got {background!r}"
        )
    look, policy = _look(file, data, policy)
    make = {"orbit": _orbit, "sweep": _sweep, "scenes": _scenes}[kinds[0]]
    jobs = make(file, data, Path(out), size, policy, look)
    if background is not None:
        jobs = [dataclasses.replace(job, background=background) for job in jobs]
    return Plan(str(file), kinds[0], jobs)
