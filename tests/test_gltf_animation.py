"""glTF animation, skins, morph targets and KHR_materials_variants (app/scene/gltf_animation.py).

Every file is written by the test as JSON with its accessors in one base64 ``data:`` buffer,
so each value the reader sees is one the test chose; the expected results are computed
here independently of the reader (the interpolations written out, the skin as each joint's
rigid motion). Bad animation data goes through ``pbs render MODEL`` in process: exit 2,
one line naming the file and the key, no image.
"""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.scene.gltf import GltfFile
from app.scene.gltf_animation import PoseError, PoseRequest
from app.scene.gltf_document import GltfError

FLOAT, UBYTE, USHORT = 5126, 5121, 5123
_TYPES = {1: "SCALAR", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
_DTYPES = {FLOAT: "<f4", UBYTE: "<u1", USHORT: "<u2"}


class Doc:
    """A glTF document grown by the test: accessors packed into one base64 buffer."""

    def __init__(self) -> None:
        self.json: dict = {
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [],
            "meshes": [],
            "accessors": [],
            "bufferViews": [],
        }
        self.blob = bytearray()

    def accessor(self, values: object, width: int, component: int = FLOAT, **extra: object) -> int:
        array = np.asarray(values, _DTYPES[component]).reshape(-1, width)
        self.blob += b"\0" * (-len(self.blob) % 4)
        data = array.tobytes()
        self.json["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        )
        self.blob += data
        entry = {
            "bufferView": len(self.json["bufferViews"]) - 1,
            "componentType": component,
            "count": len(array),
            "type": _TYPES[width],
            **extra,
        }
        if width == 3 and component == FLOAT and extra.get("position"):
            del entry["position"]
            entry["min"] = [float(v) for v in array.min(axis=0)]
            entry["max"] = [float(v) for v in array.max(axis=0)]
        self.json["accessors"].append(entry)
        return len(self.json["accessors"]) - 1

    def node(self, root: bool = True, **fields: object) -> int:
        self.json["nodes"].append(dict(fields))
        index = len(self.json["nodes"]) - 1
        if root:
            self.json["scenes"][0]["nodes"].append(index)
        return index

    def triangle(self, **primitive: object) -> int:
        """A mesh of one triangle in the XY plane."""
        pos = self.accessor([[0, 0, 0], [1, 0, 0], [0, 1, 0]], 3, position=True)
        self.json["meshes"].append({"primitives": [{"attributes": {"POSITION": pos}, **primitive}]})
        return len(self.json["meshes"]) - 1

    def animate(self, node: int, path: str, times: list, values: object, width: int,
                interpolation: str = "LINEAR", name: str | None = None) -> None:  # fmt: skip
        sampler = {
            "input": self.accessor(times, 1),
            "output": self.accessor(values, width),
            "interpolation": interpolation,
        }
        animation = {
            "channels": [{"sampler": 0, "target": {"node": node, "path": path}}],
            "samplers": [sampler],
        }
        if name is not None:
            animation["name"] = name
        self.json.setdefault("animations", []).append(animation)

    def save(self, path: Path) -> Path:
        data = base64.b64encode(bytes(self.blob)).decode()
        self.json["buffers"] = [
            {"byteLength": len(self.blob), "uri": f"data:application/octet-stream;base64,{data}"}
        ]
        path.write_text(json.dumps(self.json), encoding="utf-8")
        return path


def _prims(path: Path, **request: object) -> list:
    return GltfFile(path, pose=PoseRequest(**request)).primitives()


def _moved(tmp_path: Path, path: str, times: list, values: object, width: int,
           interpolation: str, t: float) -> np.ndarray:  # fmt: skip
    """The world matrix of a one-triangle node animated on ``path``, at time ``t``."""
    doc = Doc()
    mesh = doc.triangle()
    node = doc.node(mesh=mesh)
    doc.animate(node, path, times, values, width, interpolation, name="move")
    (prim,) = _prims(doc.save(tmp_path / "moved.gltf"), animation="move", time=t)
    return prim.world


def test_linear_translation_at_a_mid_time(tmp_path: Path) -> None:
    world = _moved(tmp_path, "translation", [0.0, 2.0], [[0, 0, 0], [4, -2, 6]], 3, "LINEAR", 0.5)
    np.testing.assert_allclose(world[:3, 3], [1.0, -0.5, 1.5], atol=1e-12)  # a quarter of the way


def test_linear_rotation_is_slerp(tmp_path: Path) -> None:
    # Identity to 120 degrees about Y: a quarter of the way is 30 degrees about Y (a linear
    # blend of the quaternions, normalised, would give 35.2 degrees).
    half = math.radians(120.0) / 2.0
    values = [[0, 0, 0, 1], [0, math.sin(half), 0, math.cos(half)]]
    world = _moved(tmp_path, "rotation", [0.0, 1.0], values, 4, "LINEAR", 0.25)
    a = math.radians(30.0)
    expected = [[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]]
    np.testing.assert_allclose(world[:3, :3], expected, atol=1e-6)  # float32 keyframes


def test_cubicspline_against_a_hand_computation(tmp_path: Path) -> None:
    # Keys at 0 s and 2 s; per key (in-tangent, value, out-tangent): v0 = 0, b0 = 1,
    # a1 = 2, v1 = 3 (x). At t = 0.5: s = 0.25, interval 2; the Hermite basis
    # h00 = 0.84375, h10 = 0.140625, h01 = 0.15625, h11 = -0.046875, so
    # x = 0.84375 * 0 + 0.140625 * 2 * 1 + 0.15625 * 3 - 0.046875 * 2 * 2 = 0.5625.
    values = [[9, 9, 9], [0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [9, 9, 9]]
    world = _moved(tmp_path, "translation", [0.0, 2.0], values, 3, "CUBICSPLINE", 0.5)
    np.testing.assert_allclose(world[:3, 3], [0.5625, 0.0, 0.0], atol=1e-12)


def test_step_holds_each_key_until_the_next(tmp_path: Path) -> None:
    values = [[0, 0, 0], [5, 0, 0], [7, 0, 0]]
    for t, x in ((0.999, 0.0), (1.0, 5.0), (1.5, 5.0), (2.0, 7.0)):
        world = _moved(tmp_path, "translation", [0.0, 1.0, 2.0], values, 3, "STEP", t)
        assert world[0, 3] == x, t


def test_a_time_outside_the_animation_is_clamped_with_a_note(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level("WARNING", logger="pbs.gltf"):
        world = _moved(tmp_path, "translation", [1.0, 2.0], [[1, 0, 0], [3, 0, 0]], 3, "LINEAR", 9)
    assert world[0, 3] == 3.0
    notes = [r.getMessage() for r in caplog.records if "outside" in r.getMessage()]
    assert len(notes) == 1 and "1..2 s" in notes[0], notes


# --- a skinned bar ------------------------------------------------------------------------

# A bar along +Y from 0 to 2, square section, rings of 4 vertices at these heights; joint
# 0 at the origin, joint 1 at y = 1 (its child). Below y = 1 a vertex follows joint 0, above
# it joint 1, at y = 1 half each.
HEIGHTS = [0.0, 0.5, 1.0, 1.5, 2.0]


def _bar(tmp_path: Path, joints_of: list | None = None) -> Path:
    doc = Doc()
    ring = np.array([[-0.1, 0, -0.1], [0.1, 0, -0.1], [0.1, 0, 0.1], [-0.1, 0, 0.1]])
    positions = np.concatenate([ring + np.array([0.0, h, 0.0]) for h in HEIGHTS])
    normals = np.concatenate([ring / np.linalg.norm(ring, axis=1, keepdims=True)] * len(HEIGHTS))
    faces = []
    for r in range(len(HEIGHTS) - 1):
        for k in range(4):
            a, b = 4 * r + k, 4 * r + (k + 1) % 4
            faces += [a, b, b + 4, a, b + 4, a + 4]
    w1 = np.clip(np.array([h for h in HEIGHTS for _ in range(4)]) - 0.5, 0.0, 1.0)
    weights = np.stack([1.0 - w1, w1, 0 * w1, 0 * w1], axis=1)
    joints = joints_of or [[0, 1, 0, 0]] * len(positions)
    attributes = {
        "POSITION": doc.accessor(positions, 3, position=True),
        "NORMAL": doc.accessor(normals, 3),
        "JOINTS_0": doc.accessor(joints, 4, UBYTE),
        "WEIGHTS_0": doc.accessor(weights, 4),
    }
    indices = doc.accessor(faces, 1, USHORT)
    doc.json["meshes"].append({"primitives": [{"attributes": attributes, "indices": indices}]})
    inverse_bind = [np.eye(4), np.eye(4)]
    inverse_bind[1][1, 3] = -1.0  # joint 1's bind pose is a translation by +1 in y
    ibm = doc.accessor(np.concatenate([m.T.reshape(-1) for m in inverse_bind]), 16)
    doc.json["skins"] = [{"joints": [1, 2], "inverseBindMatrices": ibm}]
    # The mesh node's own transform must be ignored (glTF 2.0 sec. 3.7.3).
    doc.node(mesh=0, skin=0, translation=[5.0, 0.0, 0.0])
    doc.node(children=[2])
    doc.node(root=False, translation=[0.0, 1.0, 0.0])
    # Joint 1 turns 90 degrees about +Z over one second.
    s = math.sin(math.pi / 4)
    doc.animate(2, "rotation", [0.0, 1.0], [[0, 0, 0, 1], [0, 0, s, s]], 4, name="bend")
    return doc.save(tmp_path / "bar.gltf")


def test_a_two_joint_skin_bends_the_bar(tmp_path: Path) -> None:
    path = _bar(tmp_path)
    (rest,) = _prims(path)
    (bent,) = _prims(path, animation="bend", time=1.0)
    np.testing.assert_array_equal(rest.world, np.eye(4))
    np.testing.assert_array_equal(bent.world, np.eye(4))
    # Independently: joint 1 turns the vertex about (0, 1, 0); weights blend the two joints.
    p = rest.positions
    w1 = np.clip(p[:, 1] - 0.5, 0.0, 1.0)[:, None]
    turned = (p - [0, 1, 0]) @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]]) + [0, 1, 0]
    expected = (1.0 - w1) * p + w1 * turned
    np.testing.assert_allclose(bent.positions, expected, atol=1e-6)
    top = np.argmax(p[:, 1])  # the tip now points along -x
    assert bent.positions[top, 0] < -0.8 and abs(bent.positions[top, 1] - 1.0) < 0.2
    # The tip's normals turn with it (rotation: the inverse transpose is the rotation).
    tip = p[:, 1] > 1.9
    rotated = rest.normals[tip] @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(bent.normals[tip], rotated, atol=1e-6)


def test_skinning_in_chunks_gives_the_same_vertices(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from app.scene import gltf_animation

    path = _bar(tmp_path)
    (whole,) = _prims(path, animation="bend", time=0.7)
    monkeypatch.setattr(gltf_animation, "SKIN_CHUNK", 7)  # 20 vertices: chunks of 7, 7, 6
    (chunked,) = _prims(path, animation="bend", time=0.7)
    np.testing.assert_array_equal(chunked.positions, whole.positions)
    np.testing.assert_array_equal(chunked.normals, whole.normals)


def test_joint_matrix_uses_the_pose_not_the_bind(tmp_path: Path) -> None:
    # At rest the joints stand at their bind pose: the skin gives the mesh back as written.
    (rest,) = _prims(_bar(tmp_path))
    heights = sorted({round(float(y), 6) for y in rest.positions[:, 1]})
    assert heights == HEIGHTS
    assert np.all(np.abs(rest.positions[:, 0]) <= 0.1 + 1e-6)  # not moved by the node's +5


# --- morph targets and variants -----------------------------------------------------------


def _morphed(tmp_path: Path) -> Path:
    doc = Doc()
    mesh = doc.triangle()
    delta = doc.accessor([[0, 0, 0], [0, 0, 0], [0, 0, 2]], 3)
    doc.json["meshes"][mesh]["primitives"][0]["targets"] = [{"POSITION": delta}]
    doc.json["meshes"][mesh]["weights"] = [0.25]
    node = doc.node(mesh=mesh)
    doc.animate(node, "weights", [0.0, 1.0], [0.0, 1.0], 1, name="grow")
    return doc.save(tmp_path / "morph.gltf")


def test_a_morph_target_weight(tmp_path: Path) -> None:
    path = _morphed(tmp_path)
    (rest,) = _prims(path)  # the mesh's own weight 0.25
    assert rest.positions[2, 2] == pytest.approx(0.5, abs=1e-12)
    (mid,) = _prims(path, animation="grow", time=0.5)  # the animation's weight 0.5
    assert mid.positions[2, 2] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(mid.positions[:2], rest.positions[:2])


@pytest.mark.parametrize(
    ("change", "message"),
    [("index", "99 is not one of the 4"), ("count", "2 elements, POSITION has 3")],
)
def test_morph_targets_are_checked_where_their_weights_are_0(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: str, message: str
) -> None:
    # At rest with a weight of 0 the target adds nothing and its values are not read,
    # but a target naming no accessor, or one of another length, is still bad input.
    doc = json.loads(_morphed(tmp_path).read_text())
    doc["meshes"][0]["weights"] = [0.0]
    target = doc["meshes"][0]["primitives"][0]["targets"][0]
    if change == "index":
        target["POSITION"] = 99
    else:
        doc["accessors"][target["POSITION"]]["count"] = 2
    path = tmp_path / "target.gltf"
    path.write_text(json.dumps(doc))
    line = _render(capsys, path)
    key = "meshes[0].primitives[0].targets[0].POSITION"
    assert line == f"pbs: error: {path}: {key}: {message}", line


def test_a_cubicspline_morph_weight(tmp_path: Path) -> None:
    # The translation case's spline as the weight (0.5625 at 0.5 s), the target's delta 2.
    doc = json.loads(_morphed(tmp_path).read_text())
    path = tmp_path / "cubic-morph.gltf"
    path.write_text(json.dumps(doc))
    built = Doc()
    built.json, built.blob = (
        doc,
        bytearray(base64.b64decode(doc["buffers"][0]["uri"].split(",")[1])),
    )
    sampler = doc["animations"][0]["samplers"][0]
    sampler["input"] = built.accessor([0.0, 2.0], 1)
    sampler["output"] = built.accessor([9.0, 0.0, 1.0, 2.0, 3.0, 9.0], 1)
    sampler["interpolation"] = "CUBICSPLINE"
    (prim,) = _prims(built.save(path), animation="grow", time=0.5)
    assert prim.positions[2, 2] == pytest.approx(2 * 0.5625, abs=1e-12)


def _variants(tmp_path: Path) -> Path:
    doc = Doc()
    doc.triangle(
        material=0,
        extensions={"KHR_materials_variants": {"mappings": [{"material": 1, "variants": [1]}]}},
    )
    doc.node(mesh=0)
    doc.json["materials"] = [
        {"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}},
        {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 1, 1]}},
    ]
    doc.json["extensionsUsed"] = ["KHR_materials_variants"]
    doc.json["extensions"] = {
        "KHR_materials_variants": {"variants": [{"name": "red"}, {"name": "blue"}]}
    }
    return doc.save(tmp_path / "variants.gltf")


def test_variants_select_their_materials(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = _variants(tmp_path)
    with caplog.at_level("WARNING", logger="pbs.gltf"):
        (default,) = _prims(path)
    assert default.material == 0
    assert sum("material variant" in r.getMessage() for r in caplog.records) == 1
    assert _prims(path, variant="red")[0].material == 0  # no mapping: its own material
    assert _prims(path, variant="blue")[0].material == 1
    with pytest.raises(PoseError, match="'red', 'blue'"):
        _prims(path, variant="green")


# --- bad input: exit 2, one line, no image --------------------------------------------------


def _render(capsys: pytest.CaptureFixture[str], path: Path, *options: str) -> str:
    out = path.parent / "out"
    out.mkdir(exist_ok=True)
    capsys.readouterr()
    rc = main(["render", str(path), "-o", str(out / "x.png"), "--size", "32x24", *options])
    err = capsys.readouterr().err
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert not list(out.iterdir()), "no output"
    assert str(path) in lines[0] or path.name in lines[0], lines[0]
    return lines[0]


def _bad_animation(tmp_path: Path, change: str) -> Path:
    """A triangle with two animations: animations[0] with one defect (``change``), and a
    valid one named 'ok' on the same node, which ``--animation ok`` poses."""
    doc = Doc()
    node = doc.node(mesh=doc.triangle())
    if change == "type":  # a rotation given as VEC3
        doc.animate(node, "rotation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0]], 3)
    elif change == "count":  # three values for two keyframes
        doc.animate(node, "translation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0], [2, 0, 0]], 3)
    elif change == "times":  # times not increasing
        doc.animate(node, "translation", [0.0, 1.0, 1.0], [[0, 0, 0]] * 3, 3)
    elif change == "negative times":  # the specification's time[0] >= 0
        doc.animate(node, "translation", [-1.0, 1.0], [[0, 0, 0], [1, 0, 0]], 3)
    elif change == "one cubic key":  # CUBICSPLINE needs two keyframes
        doc.animate(node, "translation", [0.0], [[0, 0, 0]] * 3, 3, "CUBICSPLINE")
    elif change == "cubic count":  # two values (not 3 x 2) for two CUBICSPLINE keyframes
        doc.animate(node, "translation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0]], 3, "CUBICSPLINE")
    else:
        doc.animate(node, "translation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0]], 3)
    doc.animate(node, "translation", [0.0, 1.0], [[0, 0, 0], [0, 1, 0]], 3, name="ok")
    sampler = doc.json["animations"][0]["samplers"][0]
    channel = doc.json["animations"][0]["channels"][0]
    if change == "interpolation":
        sampler["interpolation"] = "BOGUS"
    elif change == "output index":
        sampler["output"] = 999
    elif change == "input index":
        sampler["input"] = 999
    elif change == "input type":  # keyframe times as VEC3
        sampler["input"] = sampler["output"]
    elif change == "node":
        channel["target"]["node"] = 9
    elif change == "sampler":
        channel["sampler"] = 9
    return doc.save(tmp_path / f"bad-{change.replace(' ', '-')}.gltf")


# Each defect: the key the line names and the message after it (accessors 0-2 are the
# triangle's POSITION and animations[0]'s input and output; 5 accessors in all).
BAD_ANIMATIONS = [
    ("type", "animations[0].samplers[0].output", "accessors[2]: VEC3 of componentType 5126 "
     "cannot be rotation (allowed: VEC4 of 5126, 5120, 5121, 5122, 5123)"),
    ("count", "animations[0].samplers[0].output",
     "3 values for 2 keyframes of LINEAR; 2 are needed"),
    ("times", "animations[0].samplers[0].input", "keyframe times must increase strictly: "
     "keyframe 2 (1 s) follows keyframe 1 (1 s)"),
    ("negative times", "animations[0].samplers[0].input", "keyframe times must be 0 or "
     "more: keyframe 0 is at -1 s"),
    ("one cubic key", "animations[0].samplers[0].input",
     "1 keyframe for CUBICSPLINE, which needs at least 2 keyframes"),
    ("cubic count", "animations[0].samplers[0].output",
     "2 values for 2 keyframes of CUBICSPLINE; 6 are needed"),
    ("interpolation", "animations[0].samplers[0].interpolation",
     "'BOGUS' is not LINEAR, STEP, CUBICSPLINE"),
    ("output index", "animations[0].samplers[0].output", "999 is not one of the 5"),
    ("input index", "animations[0].samplers[0].input", "999 is not one of the 5"),
    ("input type", "animations[0].samplers[0].input", "accessors[2]: VEC3 of componentType "
     "5126 cannot be input (allowed: SCALAR of 5126)"),
    ("node", "animations[0].channels[0].target.node", "9 is not one of the 1"),
    ("sampler", "animations[0].channels[0].sampler", "9 is not one of the 1 samplers"),
]  # fmt: skip


@pytest.mark.parametrize(("change", "key", "message"), BAD_ANIMATIONS)
@pytest.mark.parametrize("pose", ["rest", "posed", "another"])
def test_bad_animation_data_is_bad_input_whatever_the_pose(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: str,
    key: str,
    message: str,
    pose: str,
) -> None:
    # The rest pose, animations[0] posed and the valid animation posed give one line, in
    # the same words: the file's animations are checked by one function whatever is shown.
    options = {"rest": [], "posed": ["--time", "0.5"], "another": ["--animation", "ok"]}[pose]
    path = _bad_animation(tmp_path, change)
    line = _render(capsys, path, *options)
    assert line == f"pbs: error: {path}: {key}: {message}", line


def test_one_cubic_key_is_bad_input_where_a_linear_sampler_shares_its_times(
    tmp_path: Path,
) -> None:
    # The keyframe times an input accessor holds are checked once for all the samplers
    # that share it; the CUBICSPLINE sampler's need of two keyframes is its own.
    doc = Doc()
    node = doc.node(mesh=doc.triangle())
    doc.animate(node, "translation", [0.0], [[0, 0, 0]], 3)
    animation = doc.json["animations"][0]
    shared = animation["samplers"][0]["input"]
    output = doc.accessor([[1, 1, 1]] * 3, 3)
    animation["samplers"].append(
        {"input": shared, "output": output, "interpolation": "CUBICSPLINE"}
    )
    animation["channels"].append({"sampler": 1, "target": {"node": node, "path": "scale"}})
    path = doc.save(tmp_path / "shared.gltf")
    with pytest.raises(GltfError) as caught:
        _prims(path)
    assert caught.value.key == "animations[0].samplers[1].input", caught.value


def test_a_weights_output_of_another_count_is_bad_input_at_rest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = json.loads(_morphed(tmp_path).read_text())
    doc["accessors"][doc["animations"][0]["samplers"][0]["output"]]["count"] = 1
    path = tmp_path / "weights-count.gltf"
    path.write_text(json.dumps(doc))
    expected = (
        f"pbs: error: {path}: animations[0].samplers[0].output: 1 weights for 2 keyframes "
        "of LINEAR; nodes[0]'s mesh has 1 morph targets, so 2 are needed"
    )
    for options in ([], ["--time", "0.5"]):
        assert _render(capsys, path, *options) == expected


def test_an_index_out_of_range_names_its_key_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # An accessor index past the table, where the reader's index check and the animation's
    # own naming of the sampler or skin both added the key: named once.
    for key in ("animations[0].samplers[0].output", "animations[0].samplers[0].input"):
        doc = json.loads(_bar(tmp_path).read_text())
        doc["animations"][0]["samplers"][0][key.rsplit(".", 1)[1]] = 999
        path = tmp_path / "index.gltf"
        path.write_text(json.dumps(doc))
        for options in ([], ["--time", "0.5"]):
            line = _render(capsys, path, *options)
            assert line == f"pbs: error: {path}: {key}: 999 is not one of the 8", line
    doc = json.loads(_bar(tmp_path).read_text())
    doc["skins"][0]["inverseBindMatrices"] = 999
    path.write_text(json.dumps(doc))
    line = _render(capsys, path)
    expected = f"pbs: error: {path}: skins[0].inverseBindMatrices: 999 is not one of the 8"
    assert line == expected, line


def test_the_rest_pose_reads_keyframe_times_not_values(tmp_path: Path) -> None:
    # The rest pose checks every sampler's output from the JSON (type, count) and reads
    # only the times (one number per keyframe): its cost stays that of the mesh.
    path = _bar(tmp_path)
    sampler = json.loads(path.read_text())["animations"][0]["samplers"][0]
    gltf = GltfFile(path)
    gltf.primitives()
    read = {index for index, _ in gltf._accessors}
    assert sampler["input"] in read and sampler["output"] not in read
    posed = GltfFile(path, pose=PoseRequest(time=0.5))
    posed.primitives()
    assert sampler["output"] in {index for index, _ in posed._accessors}


def test_joints_out_of_range_are_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _bar(tmp_path, joints_of=[[0, 2, 0, 0]] * 20)  # the skin has joints 0 and 1
    line = _render(capsys, path)
    assert "meshes[0].primitives[0].attributes.JOINTS_0" in line and "joint 2" in line, line


def test_a_weights_count_mismatch_is_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = json.loads(_morphed(tmp_path).read_text())
    doc["meshes"][0]["weights"] = [0.25, 0.5]  # one target
    del doc["animations"]
    path = tmp_path / "weights.gltf"
    path.write_text(json.dumps(doc))
    line = _render(capsys, path)
    assert "meshes[0].weights" in line and "2 weights for 1 morph targets" in line, line


def test_an_unknown_animation_lists_the_file_s(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = _render(capsys, _bar(tmp_path), "--animation", "walk")
    assert "--animation" in line and "no animation 'walk'" in line and "0 'bend'" in line, line


def test_an_unknown_variant_lists_the_file_s(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = _render(capsys, _variants(tmp_path), "--variant", "green")
    assert "--variant" in line and "'red', 'blue'" in line, line


def test_a_time_for_a_file_without_animations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = Doc()
    doc.node(mesh=doc.triangle())
    line = _render(capsys, doc.save(tmp_path / "still.gltf"), "--time", "1")
    assert "--time" in line and "no animations" in line, line


# --- EXT_texture_webp and KHR_texture_basisu ---------------------------------------------


def _image_uri(colour: tuple[int, int, int], fmt: str) -> str:
    import io

    from PIL import Image

    buffer = io.BytesIO()
    options = {"lossless": True} if fmt == "WEBP" else {}
    Image.new("RGB", (4, 4), colour).save(buffer, fmt, **options)
    mime = {"WEBP": "image/webp", "PNG": "image/png"}[fmt]
    return f"data:{mime};base64,{base64.b64encode(buffer.getvalue()).decode()}"


def _textured(tmp_path: Path, extension: str, fallback: bool = True) -> Path:
    """A triangle whose base colour texture is a WebP (green) or a KTX2 image (here bytes
    no decoder reads), with a red PNG as the texture's fallback ``source``."""
    doc = Doc()
    doc.node(mesh=doc.triangle(material=0))
    doc.json["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    (tmp_path / "x.ktx2").write_bytes(b"\xabKTX 20\xbb\r\n\x1a\n" + bytes(64))
    special = (
        {"uri": _image_uri((0, 255, 0), "WEBP")} if extension == "EXT_texture_webp"
        else {"uri": "x.ktx2", "mimeType": "image/ktx2"}
    )  # fmt: skip
    doc.json["images"] = [{"uri": _image_uri((255, 0, 0), "PNG")}, special]
    texture: dict = {"extensions": {extension: {"source": 1}}}
    if fallback:
        texture["source"] = 0
    doc.json["textures"] = [texture]
    doc.json["extensionsUsed"] = [extension]
    return doc.save(tmp_path / f"{extension}.gltf")


def _base_colour(path: Path) -> np.ndarray:
    from app.scene.geometry import _DEFAULT_MATERIAL

    layer = GltfFile(path).layer(0, _DEFAULT_MATERIAL, "naive")
    return np.asarray(layer.maps["base_color"].pixels)[0, 0, :3]


def test_a_webp_texture_is_read(tmp_path: Path) -> None:
    np.testing.assert_array_equal(
        _base_colour(_textured(tmp_path, "EXT_texture_webp")), [0, 255, 0]
    )


def test_a_ktx2_texture_falls_back_with_a_note(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _textured(tmp_path, "KHR_texture_basisu")
    with caplog.at_level("WARNING", logger="pbs.gltf"):
        np.testing.assert_array_equal(_base_colour(path), [255, 0, 0])
    notes = [r.getMessage() for r in caplog.records if "KHR_texture_basisu" in r.getMessage()]
    assert len(notes) == 1 and "images[0]" in notes[0], notes
    line = _render(capsys, _textured(tmp_path, "KHR_texture_basisu", fallback=False))
    assert "textures[0].source" in line and "no PNG or JPEG fallback" in line, line


# --- pbs batch: a pose in the look table, time swept as a scene key ------------------------


def test_a_job_file_poses_a_model_and_sweeps_its_time(tmp_path: Path) -> None:
    from app.batch.jobs import plan_jobs
    from app.errors import InputError

    _bar(tmp_path)
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(
        'scene = "bar.gltf"\nlook = { animation = 0, variant = "v", time = 0.5 }\n'
        'sweep = { key = "objects[0].time", values = [0.0, 1.0] }\n'
    )
    with pytest.raises(InputError, match="variant"):  # the file has no variants
        plan_jobs(jobs, tmp_path / "out")
    jobs.write_text(jobs.read_text().replace(', variant = "v"', ""))
    plan = plan_jobs(jobs, tmp_path / "out")
    assert [job.value for job in plan.jobs] == [0.0, 1.0]
    assert plan.jobs[0].look is not None and plan.jobs[0].look.pose() == {
        "animation": "0",
        "time": 0.5,
    }
    jobs.write_text('scene = "bar.gltf"\nlook = { time = "noon" }\norbit = { frames = 1 }\n')
    with pytest.raises(InputError, match=r"look\.time"):
        plan_jobs(jobs, tmp_path / "out")


@pytest.mark.gl
def test_a_time_sweep_renders_the_bar_bending(tmp_path: Path) -> None:
    from PIL import Image

    _bar(tmp_path)
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(
        'scene = "bar.gltf"\nsize = "48x48"\nlook = { animation = "bend", view = "front" }\n'
        'sweep = { key = "objects[0].time", values = [0.0, 1.0] }\n'
    )
    assert main(["batch", str(jobs), "-o", str(tmp_path / "out"), "-q"]) == 0
    first, last = (
        np.asarray(Image.open(tmp_path / "out" / f"sweep-000{i}.png"), np.int16) for i in (0, 1)
    )
    # The camera stays (framed at the sweep's base); the bar's tip leaves the top middle
    # and the bent part reaches the left of the image.
    assert np.abs(first - last).max() > 50
    background = first[0, 0]
    drawn = np.abs(last - background).sum(axis=2) > 30
    assert (
        drawn[:, : 48 // 3].any()
        and not (np.abs(first - background).sum(axis=2) > 30)[:, : 48 // 3].any()
    )


# --- a real asset: Cesium Man walking (tests/assets/CesiumMan.glb, CC-BY 4.0 Cesium) -----

CESIUM_MAN = Path(__file__).resolve().parent / "assets" / "CesiumMan.glb"


def _extent(time: float | None) -> tuple[np.ndarray, float]:
    """(the world-space box size of the posed man, his longest triangle edge)."""
    (prim,) = _prims(CESIUM_MAN, time=time)
    world = prim.positions @ prim.world[:3, :3].T + prim.world[:3, 3]
    edges = world[prim.faces] - world[np.roll(prim.faces, 1, axis=1)]
    return np.ptp(world, axis=0), float(np.linalg.norm(edges, axis=2).max())


def test_cesium_man_walks() -> None:
    rest, rest_edge = _extent(None)
    # At rest the joints stand in the bind pose: a T-pose, arms out (1.14 m wide, 0.31 deep).
    assert rest[0] > 1.0 and rest[2] < 0.4, rest
    for time in (0.5, 1.0, 1.5):
        size, edge = _extent(time)
        # Walking: arms down (narrow), legs apart (deep), as tall (1.46-1.51 m), and no
        # triangle torn (a wrong joint matrix scatters vertices across the model).
        assert size[0] < 0.55 and size[2] > 0.6 and abs(size[1] - rest[1]) < 0.06, (time, size)
        assert edge < 1.3 * rest_edge, (time, edge, rest_edge)
    assert _extent(1.0)[0][2] > _extent(0.5)[0][2] + 0.15  # the stride opens from 0.5 s to 1 s


@pytest.mark.gl
def test_cesium_man_renders_at_two_times() -> None:
    from app.api import OffscreenRenderer
    from app.scene.look import Look

    images = []
    for time in (0.5, 1.0):
        with OffscreenRenderer(CESIUM_MAN, size=(64, 64), look=Look("front", time=time)) as r:
            image = r.render().astype(np.int16)
            images.append((image, r.depth() > 0.0))
    (first, covered_first), (second, covered_second) = images
    assert 0.05 < covered_first.mean() < 0.6 and 0.05 < covered_second.mean() < 0.6
    assert (covered_first != covered_second).mean() > 0.02  # the legs and arms moved
    assert np.abs(first - second).max() > 50


def test_a_scene_file_poses_its_gltf_object(tmp_path: Path) -> None:
    from app.errors import InputError
    from app.scene.geometry import build_parts
    from app.scene.loader import load_scene

    _bar(tmp_path)
    scene = tmp_path / "scene.toml"
    base = '[[objects]]\nshape = "mesh"\nfile = "bar.gltf"\nposition = [0.0, 0.0, 3.0]\n'
    scene.write_text(base + 'animation = "bend"\ntime = 1.0\n')
    (part,) = build_parts(load_scene(scene))
    tip = part.vertices[:, :3].astype(np.float64) @ part.model[:3, :3].T + part.model[:3, 3]
    assert tip[:, 0].min() < -0.8 and tip[:, 2].min() > 2.8  # bent, and placed by the object
    scene.write_text(base + 'animation = "walk"\n')
    with pytest.raises(InputError) as caught:
        build_parts(load_scene(scene))
    assert caught.value.key == "objects[0].animation" and "0 'bend'" in str(caught.value)
    scene.write_text(base + "animation = -1\n")
    with pytest.raises(InputError, match="name or its index") as caught:
        load_scene(scene)
    assert caught.value.key == "objects[0].animation"
    scene.write_text(base.replace("bar.gltf", "bar.obj") + "time = 1.0\n")
    with pytest.raises(InputError, match="needs a glTF file"):
        load_scene(scene)


def test_an_extension_the_reader_does_not_honour_gets_one_note(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    doc = Doc()
    doc.node(mesh=doc.triangle())
    doc.json["extensionsUsed"] = ["EXT_mesh_gpu_instancing", "KHR_texture_transform"]
    path = doc.save(tmp_path / "instanced.gltf")
    with caplog.at_level("WARNING", logger="pbs.gltf"):
        gltf = GltfFile(path)
        gltf.primitives()
        gltf.primitives()
    notes = [r.getMessage() for r in caplog.records]
    assert len(notes) == 1 and "EXT_mesh_gpu_instancing" in notes[0], notes


def test_pose_accessors_are_charged_before_they_are_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A sampler input of 16M times and no bufferView (zeros): refused by the budget
    # before 400 MB of float64 exist, not read and then refused for its times.
    doc = Doc()
    node = doc.node(mesh=doc.triangle())
    doc.animate(node, "translation", [0.0, 1.0], [[0, 0, 0], [1, 0, 0]], 3)
    doc.json["accessors"].append({"componentType": FLOAT, "count": 1 << 24, "type": "SCALAR"})
    doc.json["animations"][0]["samplers"][0]["input"] = len(doc.json["accessors"]) - 1
    line = _render(capsys, doc.save(tmp_path / "huge.gltf"), "--time", "0", "--max-memory", "64M")
    assert "accessors[3]" in line and "--max-memory" in line, line


def _rich(tmp_path: Path) -> dict:
    """The bar with a morph target, a CUBICSPLINE weights animation, a STEP translation
    and variants: every part of the pose in one small file (JSON, buffer in a data URI)."""
    doc = json.loads(_bar(tmp_path).read_text())
    rich = Doc()
    rich.json = doc
    rich.blob = bytearray(base64.b64decode(doc["buffers"][0]["uri"].split(",")[1]))
    primitive = doc["meshes"][0]["primitives"][0]
    primitive["targets"] = [{"POSITION": rich.accessor(np.full((20, 3), 0.1), 3)}]
    primitive["material"] = 0
    primitive["extensions"] = {
        "KHR_materials_variants": {"mappings": [{"material": 1, "variants": [0]}]}
    }
    doc["meshes"][0]["weights"] = [0.5]
    doc["materials"] = [{}, {"pbrMetallicRoughness": {"metallicFactor": 0.0}}]
    doc["extensions"] = {"KHR_materials_variants": {"variants": [{"name": "v"}]}}
    doc["nodes"].append({"mesh": 0, "translation": [0.0, 0.0, 1.0]})
    doc["scenes"][0]["nodes"].append(3)
    sampler_weights = {
        "input": rich.accessor([0.0, 1.0], 1),
        "output": rich.accessor([0, 0.2, 1, 1, 0.8, 0], 1),
        "interpolation": "CUBICSPLINE",
    }
    sampler_step = {
        "input": rich.accessor([0.0, 0.5, 1.0], 1),
        "output": rich.accessor([[0, 0, 1], [1, 0, 1], [2, 0, 1]], 3),
        "interpolation": "STEP",
    }
    doc["animations"].append(
        {
            "name": "all",
            "channels": [
                {"sampler": 0, "target": {"node": 3, "path": "weights"}},
                {"sampler": 1, "target": {"node": 3, "path": "translation"}},
            ],
            "samplers": [sampler_weights, sampler_step],
        }
    )
    rich.save(tmp_path / "rich.gltf")
    return json.loads((tmp_path / "rich.gltf").read_text())


def test_mutated_pose_data_is_bad_input_or_parts(tmp_path: Path) -> None:
    """300 seeded mutations of the animations, skins, targets, weights and variants of a
    file with every part of a pose: each reads or is one GltfError, nothing else."""
    import random

    from tests.test_gltf_fuzz import BAD_VALUES, _leaves

    valid = _rich(tmp_path)
    path = tmp_path / "case.gltf"
    requests = [
        PoseRequest(animation="all", time=0.7, variant="v"),
        PoseRequest(animation=0, time=0.3),
        PoseRequest(),  # the rest pose checks both animations too
    ]
    for request in requests:
        path.write_text(json.dumps(valid))
        assert len(GltfFile(path, pose=request).primitives()) == 2
    rng = random.Random(5)
    pose_keys = {"animations", "skins", "skin", "targets", "weights", "KHR_materials_variants"}
    paths = [p for p in _leaves(valid) if pose_keys & set(p)]
    outcomes = {"parts": 0, "error": 0}
    for case in range(300):
        doc = json.loads(json.dumps(valid))
        where = rng.choice(paths)
        target = doc
        for key in where[:-1]:
            target = target[key]
        value = rng.choice(BAD_VALUES)
        target[where[-1]] = value
        path.write_text(json.dumps(doc))
        try:
            GltfFile(path, pose=requests[case % 3]).primitives()
            outcomes["parts"] += 1
        except GltfError as exc:
            assert "\n" not in str(exc), (case, where, value, str(exc))
            outcomes["error"] += 1
        except Exception as exc:  # the point: nothing else escapes
            pytest.fail(f"case {case} ({where} = {value!r}): {type(exc).__name__}: {exc}")
    assert outcomes["parts"] >= 10 and outcomes["error"] >= 150, outcomes


def test_a_scene_given_default_framing_reads_its_gltf_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # A scene file with no camera or light is framed from its built parts, which the
    # frame then takes: the file is read once, so its note appears once.
    from app.frame import prepare_frame
    from app.scene.sources import scene_from

    _bar(tmp_path)
    scene = tmp_path / "scene.toml"
    scene.write_text('[[objects]]\nshape = "mesh"\nfile = "bar.gltf"\ntime = 9.0\n')
    with caplog.at_level("WARNING", logger="pbs.gltf"):
        prepare_frame(scene_from(scene))
    notes = [r.getMessage() for r in caplog.records if "outside" in r.getMessage()]
    assert len(notes) == 1, notes
