"""A glTF 2.0 file posed at one time: animations sampled, node transforms recomputed, morph
targets and skins evaluated on the CPU in float64; and ``KHR_materials_variants``' choice
of materials (docs/gltf.md, "Animation, skins, morph targets, variants").

The reader (app/scene/gltf.py) asks for a ``PoseRequest`` (an animation by name or index,
a time in seconds, a variant name) and gets a ``Pose``: the local matrices of the animated
nodes (which ``world_matrices`` uses instead of the file's) and the morph weights the
animation sets. Then, per primitive, ``morph`` adds the weighted target deltas and ``skin``
blends the vertices by their joints, vectorised over the vertices. What is computed
(glTF 2.0 specification, Khronos 2021, sec. 3.7.2.2 "Morph Targets", 3.7.3 "Skins", 3.11
"Animations" and Appendix C "Animation Sampler Interpolation Modes"):

- STEP holds a keyframe's value until the next; LINEAR interpolates linearly, rotations
  by spherical linear interpolation (the shorter arc), normalised; CUBICSPLINE is the
  cubic Hermite spline of Appendix C, each keyframe's in- and out-tangent multiplied by
  the keyframe interval t_{k+1} - t_k. Before a channel's first key its first value
  holds, after its last key its last value.
- A skinned vertex is sum_i w_i J_{j_i} v with the joint matrix J = G(joint) B (G the
  joint's world matrix in the pose, B its inverse bind matrix), over JOINTS_0/WEIGHTS_0
  and JOINTS_1/WEIGHTS_1. The specification's joint matrix is G(mesh node)^-1 G(joint) B,
  drawn under the mesh node's world matrix G(mesh node): the product is the same, so the
  skinned vertices are kept in the file's root space and drawn under the identity (no
  inverse of a possibly singular node matrix is taken). Normals are transformed by the
  blended matrix's inverse transpose (its cofactor matrix times the sign of its
  determinant, defined even where the matrix is singular), tangents by the matrix.
- Morph targets add sum_t w_t delta_t to POSITION, NORMAL and TANGENT (xyz) before
  skinning; the weights are the animation's, else the node's ``weights``, else the mesh's.

Bad animation, skin or morph data is a ``GltfError`` naming its JSON key; a choice the
file cannot honour (an animation or variant it does not have) a ``PoseError`` naming the
scene object's key (``animation``, ``time``, ``variant``). Every animation is checked
whatever the pose, the rest pose included (``checked_tracks``: indices, interpolations,
accessor types and counts from the JSON, keyframe times read: 0 or more, strictly
increasing, at least two for CUBICSPLINE), by the code that then
reads the chosen animation's values to pose it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, TypeVar

import numpy as np

from app.scene.gltf_document import GltfDocument, GltfError, JsonObject, node_matrix

# Reads accessor ``index`` for ``semantic`` (GltfFile.accessor): float64 (count, n).
Reader = Callable[[object, str, str], np.ndarray]
T = TypeVar("T")


class Accessors(Protocol):
    """The file's accessors as the animation reads them (``GltfFile``), each named by the
    JSON key that points at it: ``accessor`` reads one for a semantic as float64
    (count, n); ``accessor_count`` checks it from the JSON alone (index, type,
    componentType, normalized) and gives its count, reading no byte."""

    def accessor(self, index: object, key: str, semantic: str) -> np.ndarray: ...

    def accessor_count(self, index: object, key: str, semantic: str) -> int: ...


INTERPOLATIONS = ("LINEAR", "STEP", "CUBICSPLINE")
# A channel's target path -> the components of one keyframe value (weights: one per target).
PATHS = {"translation": 3, "rotation": 4, "scale": 3, "weights": 1}
VARIANTS = "KHR_materials_variants"
SKIN_CHUNK = 65536  # vertices skinned at once: bounds the blended matrices' memory


@dataclass(frozen=True)
class PoseRequest:
    """What to show of a file: an animation (its name, or its index), a time in seconds
    (None: the animation's start), a ``KHR_materials_variants`` variant's name. All None:
    the rest pose (the nodes' own transforms, the meshes' own weights)."""

    animation: str | int | None = None
    time: float | None = None
    variant: str | None = None


class PoseError(GltfError):
    """A choice the file cannot honour: ``option`` is the scene object's key (``animation``,
    ``time`` or ``variant``) that made it."""

    def __init__(self, option: str, message: str) -> None:
        super().__init__("", message)
        self.option = option


@dataclass(frozen=True)
class Track:
    """One animation channel checked, its keyframe values not yet read: the node and
    property it drives, its sampler's key, output accessor and interpolation, its
    keyframe times (strictly increasing) and the values per keyframe (1, or for
    weights the node's morph targets)."""

    node: int
    path: str
    skey: str
    output: int
    interpolation: str
    times: np.ndarray
    per_key: int


@dataclass(frozen=True)
class Channel:
    """One animation channel, read and checked: the node and property it drives, its
    keyframe times (strictly increasing) and values, (K, n) or, for CUBICSPLINE,
    (K, 3, n): in-tangent, value, out-tangent per keyframe."""

    node: int
    path: str
    times: np.ndarray
    values: np.ndarray
    interpolation: str


@dataclass
class Pose:
    """The animated nodes' local matrices and morph weights at ``time`` of animation
    ``animation`` (None: the rest pose, nothing replaced); ``notes``: what the caller logs."""

    local: dict[int, np.ndarray] = field(default_factory=dict)
    weights: dict[int, np.ndarray] = field(default_factory=dict)
    animation: int | None = None
    time: float | None = None
    notes: list[str] = field(default_factory=list)


# --- interpolation -------------------------------------------------------------------------


def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions (x, y, z, w) along the shorter
    arc (glTF 2.0 Appendix C), normalised; linear where the two are nearly equal."""
    q0 = q0 / np.linalg.norm(q0)
    q1 = q1 / np.linalg.norm(q1)
    d = float(q0 @ q1)
    if d < 0.0:  # q and -q are one rotation: take the shorter way
        q1, d = -q1, -d
    if d > 1.0 - 1e-12:
        out = (1.0 - s) * q0 + s * q1
    else:
        a = math.acos(d)
        out = (math.sin((1.0 - s) * a) * q0 + math.sin(s * a) * q1) / math.sin(a)
    return out / np.linalg.norm(out)


def sample(channel: Channel, t: float) -> np.ndarray:
    """The channel's value at time ``t`` (float64; a rotation normalised)."""
    times = channel.times
    cubic = channel.interpolation == "CUBICSPLINE"
    values = channel.values[:, 1] if cubic else channel.values
    if t <= times[0]:
        out = values[0].copy()
    elif t >= times[-1]:
        out = values[-1].copy()
    else:
        k = int(np.searchsorted(times, t, side="right")) - 1  # times[k] <= t < times[k+1]
        interval = float(times[k + 1] - times[k])
        s = (t - float(times[k])) / interval
        if channel.interpolation == "STEP":
            out = values[k].copy()
        elif not cubic:
            if channel.path == "rotation":
                return slerp(values[k], values[k + 1], s)
            out = (1.0 - s) * values[k] + s * values[k + 1]
        else:
            # Appendix C: p(s) = (2s^3 - 3s^2 + 1) v_k + (s^3 - 2s^2 + s) td b_k
            #                  + (-2s^3 + 3s^2) v_k+1 + (s^3 - s^2) td a_k+1
            s2, s3 = s * s, s * s * s
            out_tangent = channel.values[k, 2]
            in_tangent = channel.values[k + 1, 0]
            out = (
                (2 * s3 - 3 * s2 + 1) * values[k]
                + (s3 - 2 * s2 + s) * interval * out_tangent
                + (-2 * s3 + 3 * s2) * values[k + 1]
                + (s3 - s2) * interval * in_tangent
            )
    if channel.path == "rotation":
        length = float(np.linalg.norm(out))
        if not length > 1e-12:
            raise GltfError("", f"a rotation of nodes[{channel.node}] samples to zero length")
        out = out / length
    return out


# --- reading an animation ------------------------------------------------------------------


def _names(entries: list, noun: str) -> str:
    """``0 'Walk', 1 'Run'``: the index and name of each entry, for a list of choices."""
    shown = [
        f"{i} {entry.name!r}" if isinstance(entry.name, str) else f"{i} (unnamed)"
        for i, entry in enumerate(entries[:20])
    ]
    more = f", ... ({len(entries)} {noun}s)" if len(entries) > 20 else ""
    return ", ".join(shown) + more


def choose_animation(doc: GltfDocument, request: PoseRequest) -> int | None:
    """The index of the animation ``request`` names (by name first, then by index; the
    first animation where only a time is given); None for the rest pose."""
    animations = doc.animations or []
    if request.animation is None and request.time is None:
        return None
    option = "animation" if request.animation is not None else "time"
    if not animations:
        raise PoseError(option, "the file has no animations")
    wanted = request.animation
    if wanted is None:
        return 0
    if isinstance(wanted, str):
        for i, animation in enumerate(animations):
            if animation.name == wanted:
                return i
        if wanted.isdigit() and int(wanted) < len(animations):
            return int(wanted)
    elif 0 <= wanted < len(animations):
        return wanted
    raise PoseError(
        "animation", f"no animation {wanted!r}; the file has: {_names(animations, 'animation')}"
    )


def target_count(doc: GltfDocument, node: int) -> int:
    """The number of morph targets of node ``node``'s mesh (0 without a mesh)."""
    mesh = doc.nodes[node].mesh
    meshes = doc.meshes or []
    if mesh is None or not 0 <= mesh < len(meshes):
        return 0
    return max((len(p.targets or []) for p in meshes[mesh].primitives or []), default=0)


def _via(get: Callable[[object, str, str], T], index: object, key: str, semantic: str) -> T:
    """``get(index, key, semantic)`` (an accessor read or counted) with any error named
    by ``key``, the property that points at the accessor, once: ``key: accessors[3]:
    ...`` where the accessor itself is at fault, the error as it is where it already
    names ``key`` (an index out of range)."""
    try:
        return get(index, key, semantic)
    except GltfError as exc:
        if exc.key == key or exc.key.startswith(f"{key}."):
            raise
        raise GltfError(key, str(exc)) from None


def _sampler(
    sampler: JsonObject, skey: str, accessors: Accessors, checked: dict[int, np.ndarray]
) -> tuple[np.ndarray, str]:
    """A sampler's keyframe times (float SCALAR, finite, 0 or more, strictly increasing;
    at least two for CUBICSPLINE) and its interpolation, checked; ``checked``: the times
    of the input accessors checked so far (samplers often share one). The bounds are
    the specification's (glTF 2.0, ``animation.sampler``: ``time[0] >= 0``,
    ``time[n + 1] > time[n]``, "at least two keyframes" for CUBICSPLINE)."""
    interpolation = sampler.interpolation if sampler.interpolation is not None else "LINEAR"
    if interpolation not in INTERPOLATIONS:
        raise GltfError(
            f"{skey}.interpolation", f"{interpolation!r} is not {', '.join(INTERPOLATIONS)}"
        )
    times = checked.get(sampler.input)
    if times is None:
        times = _via(accessors.accessor, sampler.input, f"{skey}.input", "input")[:, 0]
        negative = times < 0.0
        if negative.any():
            k = int(np.argmax(negative))
            raise GltfError(
                f"{skey}.input",
                f"keyframe times must be 0 or more: keyframe {k} is at {times[k]:g} s",
            )
        increasing = times[1:] > times[:-1]
        if not increasing.all():
            k = int(np.argmin(increasing))
            raise GltfError(
                f"{skey}.input",
                f"keyframe times must increase strictly: keyframe {k + 1} ({times[k + 1]:g} s) "
                f"follows keyframe {k} ({times[k]:g} s)",
            )
        checked[sampler.input] = times
    if interpolation == "CUBICSPLINE" and len(times) < 2:
        raise GltfError(
            f"{skey}.input", "1 keyframe for CUBICSPLINE, which needs at least 2 keyframes"
        )
    return times, interpolation


def checked_tracks(
    doc: GltfDocument, index: int, accessors: Accessors, notes: list[str]
) -> list[Track]:
    """Animation ``index`` checked without reading its keyframe values: every sampler's
    interpolation and input times (float SCALAR, 0 or more, strictly increasing, at least
    two for CUBICSPLINE: one number per keyframe, read), every channel's node and
    sampler, and each output accessor's type and count from the JSON (the path's type; as
    many values as the interpolation needs: 3 per keyframe for CUBICSPLINE, times the
    targets for weights). The rest pose checks every animation this way; posing reads
    the chosen one's values after it."""
    animation = doc.animations[index]
    akey = f"animations[{index}]"
    nodes = doc.nodes or []
    samplers = animation.samplers or []
    inputs: dict[int, np.ndarray] = {}
    checked = [
        _sampler(sampler, f"{akey}.samplers[{s}]", accessors, inputs)
        for s, sampler in enumerate(samplers)
    ]
    tracks: list[Track] = []
    for c, channel in enumerate(animation.channels or []):
        ckey = f"{akey}.channels[{c}]"
        target = channel.target
        path = target.path
        if path not in PATHS:
            notes.append(f"{ckey}.target.path: {path!r} is not animated by pbs (ignored)")
            continue
        if target.node is None:
            notes.append(f"{ckey}.target: no node (an extension's target): ignored")
            continue
        if not 0 <= target.node < len(nodes):
            raise GltfError(f"{ckey}.target.node", f"{target.node} is not one of the {len(nodes)}")
        if not 0 <= channel.sampler < len(samplers):
            raise GltfError(
                f"{ckey}.sampler", f"{channel.sampler} is not one of the {len(samplers)} samplers"
            )
        node = target.node
        if nodes[node].matrix is not None:
            raise GltfError(
                f"nodes[{node}].matrix",
                "an animated node must give translation, rotation and scale, not a matrix",
            )
        per_key = 1  # output rows per keyframe value: one, or one weight per target
        if path == "weights":
            per_key = target_count(doc, node)
            if per_key == 0:
                raise GltfError(
                    f"{ckey}.target",
                    f"animates the weights of nodes[{node}], which has no morph targets",
                )
        s = channel.sampler
        times, interpolation = checked[s]
        skey = f"{akey}.samplers[{s}]"
        output = samplers[s].output
        count = _via(accessors.accessor_count, output, f"{skey}.output", path)
        per_time = (3 if interpolation == "CUBICSPLINE" else 1) * per_key
        needed = per_time * len(times)
        if count != needed:
            given = f"{count} {'weights' if path == 'weights' else 'values'}"
            why = ""
            if path == "weights":
                why = f"nodes[{node}]'s mesh has {per_key} morph targets, so "
            raise GltfError(
                f"{skey}.output",
                f"{given} for {len(times)} keyframes of {interpolation}; {why}{needed} are needed",
            )
        tracks.append(Track(node, path, skey, output, interpolation, times, per_key))
    return tracks


def read_channels(
    doc: GltfDocument, index: int, accessors: Accessors, notes: list[str]
) -> list[Channel]:
    """Animation ``index``'s channels: checked (``checked_tracks``), then their keyframe
    values read (finite, within the accessor's bounds) and shaped (K, n) or, for
    CUBICSPLINE, (K, 3, n)."""
    channels = []
    for track in checked_tracks(doc, index, accessors, notes):
        values = _via(accessors.accessor, track.output, f"{track.skey}.output", track.path)
        width = track.per_key if track.path == "weights" else PATHS[track.path]
        keys = len(track.times)
        shape = (keys, 3, width) if track.interpolation == "CUBICSPLINE" else (keys, width)
        channel = Channel(
            track.node, track.path, track.times, values.reshape(shape), track.interpolation
        )
        channels.append(channel)
    return channels


def _rest(node: JsonObject) -> dict[str, list[float]]:
    """A node's own translation, rotation and scale (glTF's defaults where absent)."""
    return {
        "translation": list(node.translation or [0.0, 0.0, 0.0]),
        "rotation": list(node.rotation or [0.0, 0.0, 0.0, 1.0]),
        "scale": list(node.scale or [1.0, 1.0, 1.0]),
    }


def posed(doc: GltfDocument, request: PoseRequest, accessors: Accessors) -> Pose:
    """The pose ``request`` asks for: the chosen animation's channels sampled at the
    time (clamped into the animation's range, with a note where it was outside), the
    animated nodes' local matrices and weights; the rest pose without an animation, with
    a note where the file has animations. Every animation is checked whatever the pose
    (``checked_tracks``): bad animation data is bad input even where it is not shown."""
    pose = Pose()
    index = choose_animation(doc, request)
    animations = doc.animations or []
    for other in range(len(animations)):
        if other != index:
            checked_tracks(doc, other, accessors, [])  # its notes are for posing it
    if index is None:
        if animations:
            pose.notes.append(
                f"has {len(animations)} animation(s) ({_names(animations, 'animation')}); "
                "shown in its rest pose: --animation and --time (a scene object's "
                "animation and time) pose it"
            )
        return pose
    channels = read_channels(doc, index, accessors, pose.notes)
    start = min((float(c.times[0]) for c in channels), default=0.0)
    end = max((float(c.times[-1]) for c in channels), default=0.0)
    t = start if request.time is None else float(request.time)
    if not start <= t <= end:
        clamped = min(max(t, start), end)
        pose.notes.append(
            f"time {t:g} s is outside animation {index}'s {start:g}..{end:g} s: "
            f"shown at {clamped:g} s (a still does not loop)"
        )
        t = clamped
    pose.animation, pose.time = index, t
    trs: dict[int, dict[str, list[float]]] = {}
    for channel in channels:
        try:
            value = sample(channel, t)
        except GltfError as exc:
            raise GltfError(f"animations[{index}]", exc.message) from None
        if channel.path == "weights":
            pose.weights[channel.node] = value
        else:
            parts = trs.setdefault(channel.node, _rest(doc.nodes[channel.node]))
            parts[channel.path] = [float(x) for x in value]
    for node, parts in trs.items():
        if not all(math.isfinite(x) and abs(x) <= 1e9 for v in parts.values() for x in v):
            raise GltfError(f"animations[{index}]", f"samples nodes[{node}] past 1e9 or NaN")
        pose.local[node] = node_matrix(JsonObject(parts), node)
    return pose


# --- morph targets and skins ---------------------------------------------------------------


def morph_weights(
    doc: GltfDocument, node: int, mesh: int, targets: int, pose: Pose
) -> np.ndarray | None:
    """The morph weights of node ``node`` (showing mesh ``mesh`` with ``targets``
    targets): the pose's, else the node's, else the mesh's, else zeros; None without
    targets. A count other than ``targets`` is bad input."""
    if targets == 0:
        return None
    if node in pose.weights:
        return pose.weights[node]
    for key, given in (
        (f"nodes[{node}].weights", doc.nodes[node].weights),
        (f"meshes[{mesh}].weights", doc.meshes[mesh].weights),
    ):
        if given is not None:
            if len(given) != targets:
                raise GltfError(key, f"{len(given)} weights for {targets} morph targets")
            return np.asarray(given, np.float64)
    return np.zeros(targets)


def morph(
    attrs: dict[str, np.ndarray], deltas: list[dict[str, np.ndarray]], weights: np.ndarray
) -> dict[str, np.ndarray]:
    """``attrs`` with each target's POSITION, NORMAL and TANGENT (xyz) deltas added,
    weighted (glTF 2.0 sec. 3.7.2.2); the tangent's w is kept."""
    out = dict(attrs)
    for name in ("POSITION", "NORMAL", "TANGENT"):
        if name not in attrs:
            continue
        base = attrs[name].copy()
        for w, target in zip(weights, deltas, strict=True):
            if name in target and w != 0.0:
                base[:, :3] += w * target[name]
        out[name] = base
    return out


def joint_matrices(
    doc: GltfDocument, skin: int, worlds: dict[int, np.ndarray], read: Reader
) -> np.ndarray:
    """(J, 4, 4): each joint's world matrix in the pose times its inverse bind matrix
    (identity where the skin gives none)."""
    skins = doc.skins or []
    if not 0 <= skin < len(skins):
        raise GltfError("skins", f"skin {skin} is not one of the {len(skins)}")
    entry = skins[skin]
    key = f"skins[{skin}]"
    joints = list(entry.joints or [])
    for j, node in enumerate(joints):
        if node not in worlds:
            raise GltfError(f"{key}.joints[{j}]", f"node {node} is not in the shown scene")
    if entry.inverseBindMatrices is None:
        inverse_bind = np.broadcast_to(np.eye(4), (len(joints), 4, 4))
    else:
        ikey = f"{key}.inverseBindMatrices"
        rows = _via(read, entry.inverseBindMatrices, ikey, "inverseBindMatrices")
        if len(rows) != len(joints):
            raise GltfError(ikey, f"{len(rows)} matrices for {len(joints)} joints")
        inverse_bind = rows.reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
    world = np.stack([worlds[node] for node in joints])
    return world @ inverse_bind


def skin(
    attrs: dict[str, np.ndarray],
    sets: list[tuple[np.ndarray, np.ndarray]],
    matrices: np.ndarray,
) -> dict[str, np.ndarray]:
    """``attrs`` skinned: per vertex the blended matrix M = sum_i w_i J[j_i] over the
    (joints, weights) sets; positions by M, normals by M's inverse transpose (cofactor
    matrix times the determinant's sign), tangents (xyz) by M, w kept. Joint indices are
    checked by the caller."""
    n = len(attrs["POSITION"])
    out = {name: values.copy() for name, values in attrs.items()}
    for start in range(0, n, SKIN_CHUNK):  # bounded temporaries (48 float64 per vertex)
        part = slice(start, min(start + SKIN_CHUNK, n))
        blended = np.zeros((part.stop - start, 3, 4))
        for joints, weights in sets:
            for c in range(joints.shape[1]):
                blended += weights[part, c, None, None] * matrices[joints[part, c], :3]
        m3 = blended[:, :, :3]
        p = attrs["POSITION"][part, :3]
        out["POSITION"][part, :3] = np.einsum("nij,nj->ni", m3, p) + blended[:, :, 3]
        if "NORMAL" in attrs:
            a, b, c = m3[:, :, 0], m3[:, :, 1], m3[:, :, 2]
            cofactor = np.stack([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=2)
            sign = np.where(np.einsum("ni,ni->n", a, np.cross(b, c)) < 0.0, -1.0, 1.0)
            normal = attrs["NORMAL"][part, :3]
            out["NORMAL"][part, :3] = np.einsum("nij,nj->ni", cofactor, normal) * sign[:, None]
        if "TANGENT" in attrs:
            tangent = attrs["TANGENT"][part, :3]
            out["TANGENT"][part, :3] = np.einsum("nij,nj->ni", m3, tangent)
    return out


# --- KHR_materials_variants ----------------------------------------------------------------


def variant_names(doc: GltfDocument) -> list[str]:
    """The names of the file's ``KHR_materials_variants`` variants, in order."""
    ext = (doc.extensions or {}).get(VARIANTS)
    key = f"extensions.{VARIANTS}"
    if ext is None:
        return []
    if not isinstance(ext, dict) or not isinstance(ext.get("variants"), list):
        raise GltfError(key, "must be an object with a list of variants")
    names = []
    for i, variant in enumerate(ext["variants"]):
        if not isinstance(variant, dict) or not isinstance(variant.get("name"), str):
            raise GltfError(f"{key}.variants[{i}]", "must be an object with a name")
        names.append(variant["name"])
    return names


def choose_variant(doc: GltfDocument, name: str | None, notes: list[str]) -> int | None:
    """The index of variant ``name`` (None: the default materials, with a note where the
    file has variants); an unknown name is a ``PoseError`` listing the names."""
    names = variant_names(doc)
    if name is None:
        if names:
            notes.append(
                f"has {len(names)} material variant(s) ({', '.join(map(repr, names))}); "
                "shown with its default materials: --variant (a scene object's variant) "
                "picks one"
            )
        return None
    if name not in names:
        have = ", ".join(map(repr, names)) if names else "none"
        raise PoseError("variant", f"no material variant {name!r}; the file has: {have}")
    return names.index(name)


def variant_material(
    prim: JsonObject, key: str, variant: int, variants: int, materials: int
) -> int | None:
    """The material a primitive's ``KHR_materials_variants`` mappings give ``variant``
    (None: no mapping names it, so the primitive keeps its own material)."""
    ext = (prim.extensions or {}).get(VARIANTS)
    if ext is None:
        return None
    ekey = f"{key}.extensions.{VARIANTS}"
    mappings = ext.get("mappings") if isinstance(ext, dict) else None
    if not isinstance(mappings, list):
        raise GltfError(ekey, "must be an object with a list of mappings")
    for i, mapping in enumerate(mappings):
        mkey = f"{ekey}.mappings[{i}]"
        if not isinstance(mapping, dict):
            raise GltfError(mkey, "must be an object")
        material, listed = mapping.get("material"), mapping.get("variants")
        if type(material) is not int or not 0 <= material < materials:
            raise GltfError(f"{mkey}.material", f"{material!r} is not one of the {materials}")
        if not isinstance(listed, list) or not all(
            type(v) is int and 0 <= v < variants for v in listed
        ):
            raise GltfError(f"{mkey}.variants", f"must list variants below {variants}")
        if variant in listed:
            return material
    return None
