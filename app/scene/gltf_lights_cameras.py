"""A glTF file's cameras and KHR_lights_punctual lights, as the scene's own ``Camera`` and
``Light`` records (docs/gltf-lights-cameras.md).

Resolved once, at load (``app.scene.loader.parse_scene``): ``camera.from_file`` becomes an
ordinary camera and an object's ``import_lights = true`` appends ordinary lights, so every
consumer (renderer, ray-caster, viewer, API) sees a plain scene and a file camera or
light renders exactly as the same camera or light written in TOML.

Placement: the object's model matrix (scale, rotation, translation) times the node's
world matrix in the file (``world_matrices``). glTF 2.0 (sec. "Cameras") and
KHR_lights_punctual look down the node's local -Z with +Y up; both ignore the node's scale
except for its effect on position and orientation, so the directions are normalised and
range and intensity are never scaled.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from pydantic import ValidationError

from app.errors import InputError
from app.scene.gltf_document import GltfDocument, GltfError, open_gltf, world_matrices
from app.scene.model import (
    FILE_CAMERA_KEYS,
    MAX_LENGTH,
    MAX_LIGHTS,
    Camera,
    Light,
    Scene,
    SceneObject,
)
from app.scene.placement import model_matrix
from app.untrusted import RefusedError
from app.untrusted import files as untrusted_files
from app.untrusted.policy import InputPolicy

EXTENSION = "KHR_lights_punctual"
# glTF's range is optional ("infinite": plain inverse square). The project's lights need a
# finite range for the window (RTR4 §9.4, eq. 5.14) and culling: the largest length the
# scene format allows, where the window is 1 to double precision at scene scales
# (docs/gltf-lights-cameras.md, "Range").
INFINITE_RANGE = MAX_LENGTH
# glTF's zfar is optional (an infinite projection, which the project does not have): the
# scene format's own default far plane then (app/scene/model.py Camera.far), unless the
# scene gives camera.far.
DEFAULT_FAR = Camera.model_fields["far"].default
# KHR_lights_punctual's spot defaults (radians).
DEFAULT_INNER_CONE = 0.0
DEFAULT_OUTER_CONE = math.pi / 4.0


def _unit(v: np.ndarray, key: str, what: str) -> np.ndarray:
    with np.errstate(over="ignore", invalid="ignore"):  # huge or NaN entries: refused below
        length = float(np.linalg.norm(v))
    if not math.isfinite(length) or length < 1e-12:
        raise GltfError(key, f"the node's world matrix gives no {what} (a zero scale?)")
    return v / length


def _number(
    value: object, key: str, default: float | None, low: float, high: float, *, open_low: bool
) -> float | None:
    """A JSON number of the file within (low, high] (or [low, high]), or its default."""
    if value is None:
        return default
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok and (value > low if open_low else value >= low) and value <= high:
        return float(value)
    bound = f"> {low:g}" if open_low else f">= {low:g}"
    if math.isfinite(high):
        bound += f" and <= {high:g}"
    raise GltfError(key, f"must be a finite number {bound} (got {value!r})")


def _placed(doc: GltfDocument, model: np.ndarray, max_depth: int) -> dict[int, np.ndarray]:
    """Each node of the file's shown scene to ``model @ world``."""
    return {i: model @ world for i, world in world_matrices(doc, max_depth).items()}


def _frame(m: np.ndarray, key: str) -> tuple[list[float], list[float], list[float]]:
    """Position, unit forward (local -Z) and unit up (local +Y) of a placed node."""
    position = m[:3, 3]
    forward = _unit(m[:3, :3] @ [0.0, 0.0, -1.0], key, "direction (local -Z)")
    up = _unit(m[:3, :3] @ [0.0, 1.0, 0.0], key, "up (local +Y)")
    return [float(x) for x in position], [float(x) for x in forward], [float(x) for x in up]


class _Files:
    """The glTF documents a scene names, opened once each; problems as InputError."""

    def __init__(self, scene: Scene, path: Path, policy: InputPolicy) -> None:
        self.scene = scene
        self.path = path
        self.policy = policy
        self._docs: dict[int, GltfDocument] = {}

    def file(self, index: int) -> Path:
        """The object's file, confined (an InputError naming objects[i].file otherwise)."""
        try:
            return untrusted_files.confine(
                self.scene.objects[index].file or "", self.path, self.policy
            )
        except RefusedError as exc:
            raise InputError(str(self.path), f"objects[{index}].file", str(exc)) from None

    @property
    def max_depth(self) -> int:
        return self.policy.limits.max_node_depth

    def doc(self, index: int, key: str) -> GltfDocument:
        if index not in self._docs:
            try:
                self._docs[index] = open_gltf(self.file(index), self.policy)
            except GltfError as exc:
                raise self.error(index, key, exc) from None
        return self._docs[index]

    def error(self, index: int, key: str, exc: GltfError | str) -> InputError:
        """An InputError naming the scene's ``key``, the file and (for a GltfError) the
        JSON path in the file."""
        return InputError(str(self.path), key, f"{self.file(index)}: {exc}")


def _camera_object(scene: Scene, path: Path) -> int:
    """The index of the object whose file holds the camera (camera.object, or the only
    glTF object)."""
    cam = scene.camera
    gltf = [
        i
        for i, obj in enumerate(scene.objects)
        if obj.file is not None and obj.file.lower().endswith((".gltf", ".glb"))
    ]
    if cam.object is None:
        if len(gltf) == 1:
            return gltf[0]
        if not gltf:
            raise InputError(str(path), "camera.from_file", "no object of the scene is a glTF file")
        listed = ", ".join(f"objects[{i}]" for i in gltf)
        raise InputError(
            str(path), "camera.object", f"several objects are glTF files ({listed}): name one"
        )
    if isinstance(cam.object, int):
        if cam.object >= len(scene.objects):
            raise InputError(
                str(path),
                "camera.object",
                f"{cam.object} is not one of the {len(scene.objects)} objects",
            )
        index = cam.object
    else:
        named = [i for i, obj in enumerate(scene.objects) if obj.name == cam.object]
        if len(named) != 1:
            known = ", ".join(repr(o.name) for o in scene.objects if o.name) or "none named"
            why = "no object" if not named else f"{len(named)} objects"
            raise InputError(
                str(path), "camera.object", f"{why} named '{cam.object}' (objects: {known})"
            )
        index = named[0]
    if index not in gltf:
        raise InputError(str(path), "camera.object", f"objects[{index}] is not a glTF file")
    return index


def _camera_node(doc: GltfDocument, placed: dict[int, np.ndarray], wanted: str | int) -> int:
    """The node that places the wanted camera: the camera's name, its node's name, or its
    index in ``cameras``; exactly one node of the shown scene must match."""
    cameras = doc.cameras or []
    nodes = doc.nodes or []
    if not cameras:
        raise GltfError("cameras", "the file has no cameras")
    uses = [
        (n, nodes[n].camera)
        for n in placed
        if isinstance(nodes[n].camera, int) and not isinstance(nodes[n].camera, bool)
    ]
    for n, c in uses:
        if not 0 <= c < len(cameras):
            raise GltfError(f"nodes[{n}].camera", f"camera {c} does not exist ({len(cameras)})")

    def label(n: int, c: int) -> str:
        return f"cameras[{c}] '{cameras[c].name or ''}' on node {n} '{nodes[n].name or ''}'"

    if isinstance(wanted, int):
        if wanted >= len(cameras):
            raise GltfError("cameras", f"camera {wanted} does not exist ({len(cameras)} cameras)")
        matches = [(n, c) for n, c in uses if c == wanted]
    else:
        matches = [(n, c) for n, c in uses if wanted in (cameras[c].name, nodes[n].name)]
    if len(matches) == 1:
        return matches[0][0]
    listed = "; ".join(label(n, c) for n, c in uses) or "none placed by a node of the scene"
    if not matches:
        raise GltfError("cameras", f"no camera '{wanted}' in the shown scene (cameras: {listed})")
    which = "; ".join(label(n, c) for n, c in matches)
    raise GltfError("cameras", f"'{wanted}' matches several nodes ({which}): name the node")


def file_camera(scene: Scene, path: Path, files: _Files) -> Camera:
    """``camera.from_file`` as an ordinary Camera (glTF 2.0 sec. "Cameras").

    Perspective only (the project has no orthographic projection). yfov (radians) becomes
    fov_y (degrees); aspectRatio is ignored: the image size decides, the vertical field of
    view is kept. znear/zfar become near/far; without zfar ``DEFAULT_FAR``. The target is
    1 m along the view direction (a file camera has no target: give focus_distance for
    depth of field). Each of ``FILE_CAMERA_KEYS`` the scene gives replaces the file's
    value: the viewer's orbit and pbs batch write position, target and up this way."""
    cam = scene.camera
    index = _camera_object(scene, path)
    key = "camera.from_file"
    doc = files.doc(index, key)
    try:
        placed = _placed(doc, model_matrix(scene.objects[index]), files.max_depth)
        node = _camera_node(doc, placed, cam.from_file)  # type: ignore[arg-type]
        c = doc.nodes[node].camera
        camera = doc.cameras[c]
        where = f"cameras[{c}]"
        if camera.type != "perspective" or camera.perspective is None:
            raise GltfError(
                f"{where}.type",
                f"camera '{camera.name or c}' is {camera.type!r}: the project has only "
                "perspective cameras",
            )
        p = camera.perspective
        yfov = _number(p.yfov, f"{where}.perspective.yfov", None, 0.0, math.pi, open_low=True)
        if yfov is None or yfov >= math.pi:
            raise GltfError(f"{where}.perspective.yfov", f"must be in (0, pi) (got {p.yfov!r})")
        znear = _number(p.znear, f"{where}.perspective.znear", None, 0.0, MAX_LENGTH, open_low=True)
        zfar = _number(p.zfar, f"{where}.perspective.zfar", None, 0.0, MAX_LENGTH, open_low=True)
        position, forward, up = _frame(placed[node], f"nodes[{node}]")
    except GltfError as exc:
        raise files.error(index, key, exc) from None
    keys = {
        "position": position,
        "target": [p + f for p, f in zip(position, forward, strict=True)],
        "up": up,
        "fov_y": math.degrees(yfov),
        "near": cam.near if znear is None else znear,
        "far": zfar or DEFAULT_FAR,
    }
    given = cam.model_dump(include=set(FILE_CAMERA_KEYS) & cam.model_fields_set)
    rest = cam.model_dump(exclude={*FILE_CAMERA_KEYS, "from_file", "object"})
    try:
        return Camera(**(keys | given | rest))
    except ValidationError as exc:
        error = exc.errors()[0]
        field = ".".join(str(x) for x in error["loc"]) or "camera"
        raise files.error(index, key, f"the file's camera gives {field}: {error['msg']}") from None


def _file_light(light: object, j: int, m: np.ndarray, node: int, scale: float) -> dict[str, object]:
    """One KHR_lights_punctual light placed by ``m``, as Light keys. Intensity (candela
    for point and spot, lux for directional) becomes c_light = color x intensity / pi:
    the glTF Sample Viewer's and Filament's illuminance E with the Lambert 1/pi, in the
    project's convention (c_light is the radiance of a white Lambertian surface lit
    head-on, E / pi). docs/gltf-lights-cameras.md says why."""
    key = f"extensions.{EXTENSION}.lights[{j}]"
    if not isinstance(light, dict):
        raise GltfError(key, "must be an object")
    kind = light.get("type")
    if kind not in ("directional", "point", "spot"):
        raise GltfError(f"{key}.type", f"must be directional, point or spot (got {kind!r})")
    color = light.get("color", [1.0, 1.0, 1.0])
    if not isinstance(color, list) or len(color) != 3:
        raise GltfError(f"{key}.color", f"must be 3 numbers (got {color!r})")
    rgb = [_number(x, f"{key}.color", 0.0, 0.0, math.inf, open_low=False) for x in color]
    intensity = _number(
        light.get("intensity"), f"{key}.intensity", 1.0, 0.0, math.inf, open_low=False
    )
    out: dict[str, object] = {
        "type": kind,
        "color": rgb,
        "intensity": scale * intensity / math.pi,  # type: ignore[operator]
    }
    position, forward, _ = _frame(m, f"nodes[{node}]")
    if kind != "directional":
        out["position"] = position
        light_range = light.get("range")
        out["range"] = _number(
            light_range, f"{key}.range", INFINITE_RANGE, 0.0, INFINITE_RANGE, open_low=True
        )
    elif "range" in light:
        raise GltfError(f"{key}.range", "does not apply to a directional light")
    if kind != "point":
        out["direction"] = forward
    if kind == "spot":
        spot = light.get("spot")
        if not isinstance(spot, dict):
            raise GltfError(f"{key}.spot", "a spot light needs it (an object)")
        half_pi = math.pi / 2.0
        inner = _number(
            spot.get("innerConeAngle"), f"{key}.spot.innerConeAngle", DEFAULT_INNER_CONE,
            0.0, half_pi, open_low=False,
        )  # fmt: skip
        outer = _number(
            spot.get("outerConeAngle"), f"{key}.spot.outerConeAngle", DEFAULT_OUTER_CONE,
            0.0, half_pi, open_low=True,
        )  # fmt: skip
        if inner >= outer:  # type: ignore[operator]
            raise GltfError(f"{key}.spot.innerConeAngle", "must be less than outerConeAngle")
        out["inner_angle"] = math.degrees(inner)  # type: ignore[arg-type]
        out["outer_angle"] = math.degrees(outer)  # type: ignore[arg-type]
    return out


def file_lights(obj: SceneObject, index: int, path: Path, files: _Files) -> list[Light]:
    """The lights of object ``index``'s glTF file, one per node that places one (in the
    order of the file's scene, parents first), placed by the object."""
    key = f"objects[{index}].import_lights"
    doc = files.doc(index, key)
    scale = 1.0 if obj.light_scale is None else obj.light_scale
    out = []
    try:
        defined = ((doc.extensions or {}).get(EXTENSION) or {}).get("lights", [])
        if not isinstance(defined, list):
            raise GltfError(f"extensions.{EXTENSION}.lights", "must be a list")
        for node, m in _placed(doc, model_matrix(obj), files.max_depth).items():
            ext = (doc.nodes[node].extensions or {}).get(EXTENSION)
            if ext is None:
                continue
            j = ext.get("light") if isinstance(ext, dict) else None
            if not isinstance(j, int) or isinstance(j, bool) or not 0 <= j < len(defined):
                raise GltfError(
                    f"nodes[{node}].extensions.{EXTENSION}.light",
                    f"{j!r} is not one of the file's {len(defined)} lights",
                )
            keys = _file_light(defined[j], j, m, node, scale)
            try:
                out.append(Light(**keys))  # type: ignore[arg-type]
            except ValidationError as exc:
                error = exc.errors()[0]
                field = ".".join(str(x) for x in error["loc"]) or "light"
                raise GltfError(
                    f"extensions.{EXTENSION}.lights[{j}]", f"gives {field}: {error['msg']}"
                ) from None
    except GltfError as exc:
        raise files.error(index, key, exc) from None
    return out


def resolve(scene: Scene, path: Path, policy: InputPolicy) -> Scene:
    """``scene`` with ``camera.from_file`` replaced by the file's camera and the lights of
    every ``import_lights`` object appended after the scene's own (object order), those
    objects' ``import_lights`` turned off. A scene that uses neither is returned as it is."""
    wants_lights = any(obj.import_lights for obj in scene.objects)
    if scene.camera.from_file is None and not wants_lights:
        return scene
    files = _Files(scene, path, policy)
    update: dict[str, object] = {}
    if scene.camera.from_file is not None:
        update["camera"] = file_camera(scene, path, files)
    if wants_lights:
        lights = list(scene.lights)
        for i, obj in enumerate(scene.objects):
            if obj.import_lights:
                lights += file_lights(obj, i, path, files)
                if len(lights) > MAX_LIGHTS:
                    raise InputError(
                        str(path),
                        f"objects[{i}].import_lights",
                        f"brings the scene past {MAX_LIGHTS} lights",
                    )
        update["lights"] = lights
        # Imported once: the resolved scene is a plain one, so that its data validated
        # again (the Python API's edits, a batch job) does not import the lights twice.
        plain = {"import_lights": False, "light_scale": None}
        update["objects"] = [
            obj.model_copy(update=plain) if obj.import_lights else obj for obj in scene.objects
        ]
    return scene.model_copy(update=update)
