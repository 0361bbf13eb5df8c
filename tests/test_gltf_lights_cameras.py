"""A glTF file's cameras and KHR_lights_punctual lights used from a scene
(app/scene/gltf_lights_cameras.py, docs/gltf-lights-cameras.md).

The glTF files are written by the test through pygltflib: nested, rotated nodes; each
light type; spot cones and ranges. The expected placements are computed here with
explicit rotation matrices, independently of app.scene.gltf_document's quaternion code,
and one render through the real Renderer proves that a file camera and a file light are
the same, bit for bit, as the TOML camera and light they stand for.
"""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.frame.lights import light_record
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import load_scene, parse_scene

EXT = "KHR_lights_punctual"


def _rot(axis: str, degrees: float) -> np.ndarray:
    """A 3x3 rotation by ``degrees`` about a principal axis (right-handed)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def _quat(axis: str, degrees: float) -> list[float]:
    """glTF's (x, y, z, w) quaternion of the same rotation."""
    h = math.radians(degrees) / 2.0
    v = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis]
    return [math.sin(h) * a for a in v] + [math.cos(h)]


def _triangle(doc: pygltflib.GLTF2) -> None:
    """One small triangle far below everything (a glTF object must hold triangles)."""
    points = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0, 0.1]], np.float32)
    data = points.tobytes() + np.array([0, 1, 2, 0], np.uint16).tobytes()
    uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    doc.buffers = [pygltflib.Buffer(byteLength=len(data), uri=uri)]
    doc.bufferViews = [
        pygltflib.BufferView(buffer=0, byteOffset=0, byteLength=36),
        pygltflib.BufferView(buffer=0, byteOffset=36, byteLength=6),
    ]
    doc.accessors = [
        pygltflib.Accessor(bufferView=0, componentType=5126, count=3, type="VEC3",
                           min=[0, 0, 0], max=[0.1, 0, 0.1]),
        pygltflib.Accessor(bufferView=1, componentType=5123, count=3, type="SCALAR"),
    ]  # fmt: skip
    doc.meshes = [
        pygltflib.Mesh(primitives=[pygltflib.Primitive(attributes={"POSITION": 0}, indices=1)])
    ]
    doc.nodes.append(pygltflib.Node(name="tri", mesh=0, translation=[0.0, -500.0, 0.0]))
    doc.scenes[0].nodes.append(len(doc.nodes) - 1)


def _write(
    path: Path,
    nodes: list[pygltflib.Node],
    roots: list[int],
    cameras: list[pygltflib.Camera] | None = None,
    lights: list[dict] | None = None,
) -> Path:
    doc = pygltflib.GLTF2(
        asset=pygltflib.Asset(version="2.0"),
        scene=0,
        scenes=[pygltflib.Scene(nodes=list(roots))],
        nodes=list(nodes),
        cameras=cameras or [],
    )
    if lights is not None:
        doc.extensions = {EXT: {"lights": lights}}
        doc.extensionsUsed = [EXT]
    _triangle(doc)
    doc.save(str(path))
    return path


def _light_node(name: str, light: int, **kw: object) -> pygltflib.Node:
    return pygltflib.Node(name=name, extensions={EXT: {"light": light}}, **kw)


def _perspective(name: str, yfov: float, znear: float, zfar: float | None) -> pygltflib.Camera:
    return pygltflib.Camera(
        name=name,
        type="perspective",
        perspective=pygltflib.Perspective(yfov=yfov, znear=znear, zfar=zfar),
    )


SPHERE = """
[materials.m]
base_color = [0.8, 0.7, 0.6]
roughness = 0.4

[[objects]]
shape = "sphere"
material = "m"

[[objects]]
shape = "plane"
size = [8.0, 8.0]
position = [0.0, -1.0, 0.0]
material = "m"
"""


def _scene(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


# ---- the camera --------------------------------------------------------------------


def test_camera_on_nested_rotated_nodes(tmp_path: Path) -> None:
    """A camera two rotated nodes deep, in an object that is itself rotated, scaled and
    moved: position = model @ parent @ child @ origin, view direction = its local -Z, up
    = its local +Y (scale only moves it), yfov in degrees, znear/zfar as near/far."""
    nodes = [
        pygltflib.Node(name="rig", translation=[1.0, 2.0, 3.0], rotation=_quat("y", 90.0),
                       scale=[2.0, 2.0, 2.0], children=[1]),
        pygltflib.Node(name="head", translation=[0.0, 0.0, 5.0], rotation=_quat("x", -30.0),
                       camera=0),
    ]  # fmt: skip
    _write(tmp_path / "cam.gltf", nodes, [0], [_perspective("Camera_0", 0.8, 0.1, 50.0)])
    scene = _scene(
        tmp_path,
        'camera = { from_file = "Camera_0", exposure = 1.5 }\n'
        '[[objects]]\nshape = "mesh"\nfile = "cam.gltf"\nposition = [0.5, 0.0, -1.0]\n'
        "rotation = [0.0, 0.0, 90.0]\nscale = 0.5\n",
    )
    cam = load_scene(scene).scene.camera

    def affine(r: np.ndarray, t: list[float], s: float = 1.0) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = r * s
        m[:3, 3] = t
        return m

    world = (
        affine(_rot("z", 90.0), [0.5, 0.0, -1.0], 0.5)
        @ affine(_rot("y", 90.0), [1.0, 2.0, 3.0], 2.0)
        @ affine(_rot("x", -30.0), [0.0, 0.0, 5.0])
    )
    rotation = _rot("z", 90.0) @ _rot("y", 90.0) @ _rot("x", -30.0)
    np.testing.assert_allclose(cam.position, world[:3, 3], rtol=0, atol=1e-12)
    forward = np.subtract(cam.target, cam.position)
    np.testing.assert_allclose(forward, rotation @ [0, 0, -1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(cam.up, rotation @ [0, 1, 0], rtol=0, atol=1e-12)
    assert cam.fov_y == pytest.approx(math.degrees(0.8), abs=1e-12)
    assert (cam.near, cam.far, cam.exposure) == (0.1, 50.0, 1.5)
    assert cam.from_file is None  # a plain camera downstream


def test_camera_by_node_name_or_index_and_far_default(tmp_path: Path) -> None:
    """A camera is found by its node's name or its index as well; without zfar (an
    infinite projection) far is the scene format's default, and the scene's near/far
    keys win over the file's."""
    nodes = [
        pygltflib.Node(name="front", translation=[0.0, 1.0, 6.0], camera=0),
        pygltflib.Node(name="side", translation=[6.0, 1.0, 0.0], camera=1),
    ]
    cameras = [_perspective("A", 0.7, 0.2, None), _perspective("B", 0.5, 0.3, 20.0)]
    _write(tmp_path / "c.gltf", nodes, [0, 1], cameras)
    mesh = '[[objects]]\nname = "model"\nshape = "mesh"\nfile = "c.gltf"\n'
    cam = load_scene(_scene(tmp_path, 'camera = { from_file = "side" }\n' + mesh)).scene.camera
    assert cam.position == [6.0, 1.0, 0.0] and cam.far == 20.0 and cam.near == 0.3
    cam = load_scene(_scene(tmp_path, "camera = { from_file = 0 }\n" + mesh)).scene.camera
    assert cam.position == [0.0, 1.0, 6.0] and cam.target == [0.0, 1.0, 5.0]
    assert (cam.near, cam.far) == (0.2, 200.0)
    text = 'camera = { from_file = "A", object = "model", near = 0.5, far = 9.0 }\n' + mesh
    cam = load_scene(_scene(tmp_path, text)).scene.camera
    assert (cam.near, cam.far) == (0.5, 9.0)


def test_keys_beside_from_file_win_and_the_viewer_orbits(tmp_path: Path) -> None:
    """position/target/up/fov_y given beside from_file replace the file's values (the
    others stay the file's), so the viewer's orbit, which writes position, target and up
    into the scene, moves a file camera and keeps its field of view."""
    from app.viewer.document import SceneDocument

    nodes = [pygltflib.Node(name="n", translation=[0.0, 1.0, 6.0], camera=0)]
    _write(tmp_path / "o.gltf", nodes, [0], [_perspective("c", 0.6, 0.2, 30.0)])
    mesh = '[[objects]]\nshape = "mesh"\nfile = "o.gltf"\n'
    text = 'camera = { from_file = "c", target = [0.0, 0.0, 0.0], fov_y = 30.0 }\n' + mesh
    cam = load_scene(_scene(tmp_path, text)).scene.camera
    assert (cam.position, cam.target, cam.fov_y, cam.far) == (
        [0.0, 1.0, 6.0],
        [0.0] * 3,
        30.0,
        30.0,
    )
    doc = SceneDocument(_scene(tmp_path, 'camera = { from_file = "c" }\n' + mesh))
    moved = {"camera.position": [3.0, 1.0, 3.0], "camera.target": [0.0, 0.0, 0.0],
             "camera.up": [0.0, 1.0, 0.0]}  # fmt: skip
    cam = doc.edit(moved).scene.camera
    assert cam.position == [3.0, 1.0, 3.0] and cam.target == [0.0, 0.0, 0.0]
    assert cam.fov_y == pytest.approx(math.degrees(0.6)) and cam.near == 0.2


def test_a_glb_file_gives_the_same_camera_and_lights(tmp_path: Path) -> None:
    """The same document as a binary .glb (buffers in its BIN chunk): the same camera and
    lights as the .gltf."""
    nodes = [
        pygltflib.Node(name="eye", translation=[1.0, 2.0, 7.0], rotation=_quat("y", 20.0),
                       camera=0),
        _light_node("bulb", 0, translation=[0.0, 3.0, 0.0]),
    ]  # fmt: skip
    path = _write(tmp_path / "t.gltf", nodes, [0, 1], [_perspective("eye", 0.9, 0.1, 30.0)],
                  [{"type": "point", "intensity": 5.0, "range": 3.0}])  # fmt: skip
    doc = pygltflib.GLTF2.load(str(path))
    doc.convert_buffers(pygltflib.BufferFormat.BINARYBLOB)
    doc.save_binary(str(tmp_path / "t.glb"))
    scenes = []
    for name in ("t.gltf", "t.glb"):
        text = f'camera = {{ from_file = "eye" }}\n[[objects]]\nshape = "mesh"\nfile = "{name}"\n'
        scenes.append(load_scene(_scene(tmp_path, text + "import_lights = true\n")).scene)
    assert (tmp_path / "t.glb").read_bytes()[:4] == b"glTF"
    assert scenes[0].camera == scenes[1].camera and scenes[0].lights == scenes[1].lights
    assert scenes[1].lights[0].position == [0.0, 3.0, 0.0]


# ---- the lights --------------------------------------------------------------------

LIGHTS = [
    {"type": "directional", "color": [1.0, 0.5, 0.25], "intensity": 3.0},
    {"type": "point", "intensity": 40.0, "range": 7.5},
    {"type": "spot", "intensity": 20.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
    {"type": "spot", "spot": {}},  # every default: intensity 1, inner 0, outer pi/4
]


def test_each_light_type_placed_and_converted(tmp_path: Path) -> None:
    """Directional, point and spot lights on nested rotated nodes become the scene's
    lights after its own: positions and directions through model @ world, c_light =
    light_scale x color x intensity / pi, range (none: INFINITE_RANGE), cones in
    degrees with the extension's defaults."""
    nodes = [
        pygltflib.Node(name="rig", translation=[0.0, 3.0, 0.0], rotation=_quat("x", -90.0),
                       children=[1, 2, 3, 4]),
        _light_node("sun", 0, rotation=_quat("y", 30.0)),
        _light_node("bulb", 1, translation=[1.0, 2.0, 0.0], scale=[5.0, 5.0, 5.0]),
        _light_node("spot", 2, translation=[0.0, 0.0, 1.0], rotation=_quat("x", 45.0)),
        _light_node("plain", 3),
    ]  # fmt: skip
    _write(tmp_path / "l.gltf", nodes, [0], lights=LIGHTS)
    text = (
        '[[lights]]\ntype = "point"\nposition = [0.0, 1.0, 0.0]\n'
        '[[objects]]\nshape = "mesh"\nfile = "l.gltf"\nimport_lights = true\n'
        "light_scale = 2.0\nposition = [1.0, 0.0, 0.0]\n"
    )
    loaded = load_scene(_scene(tmp_path, text))
    lights = loaded.scene.lights
    assert [x.type for x in lights] == ["point", "directional", "point", "spot", "spot"]
    # resolved once: the scene's data validated again (the API's edits) is the same scene
    again = parse_scene(loaded.scene.model_dump(exclude_none=True), loaded.path).scene
    assert again == loaded.scene
    rig = _rot("x", -90.0)
    origin = np.array([1.0, 3.0, 0.0])  # object position + rig translation
    records = [light_record(x) for x in lights[1:]]
    sun, bulb, spot, plain = records
    np.testing.assert_allclose(sun.direction, rig @ _rot("y", 30.0) @ [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(sun.color, np.array([1.0, 0.5, 0.25]) * 6.0 / math.pi, rtol=1e-15)
    np.testing.assert_allclose(bulb.position, origin + rig @ [1.0, 2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(bulb.color, [80.0 / math.pi] * 3, rtol=1e-15)
    assert bulb.range == 7.5  # the node's scale does not change range
    np.testing.assert_allclose(spot.position, origin + rig @ [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(spot.direction, rig @ _rot("x", 45.0) @ [0, 0, -1], atol=1e-12)
    assert (spot.cos_inner, spot.cos_outer) == pytest.approx((math.cos(0.2), math.cos(0.5)))
    assert spot.range == 1e6
    assert (plain.cos_inner, plain.cos_outer) == pytest.approx((1.0, math.cos(math.pi / 4)))
    np.testing.assert_allclose(plain.color, [2.0 / math.pi] * 3, rtol=1e-15)
    np.testing.assert_allclose(plain.direction, rig @ [0, 0, -1], atol=1e-12)


# ---- rendered through the real Renderer --------------------------------------------


def test_file_light_and_camera_render_as_their_toml_twins(
    tmp_path: Path, gl_egl: GLContext
) -> None:
    """One image with the file's camera and directional light, one with the same camera
    and light written in TOML: bit-identical (and not black)."""
    tilt = [1.0, 0.0, 0.0, 0.0, 0.0, 0.8, -0.6, 0.0, 0.0, 0.6, 0.8, 0.0, 0.0, 0.0, 0.0, 1.0]
    side = [0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 6.0, 0.0, 0.0, 1.0]
    nodes = [
        pygltflib.Node(name="sun", matrix=tilt, extensions={EXT: {"light": 0}}),
        pygltflib.Node(name="rig", translation=[0.0, 1.0, 0.0], children=[2]),
        pygltflib.Node(name="eye", matrix=side, camera=0),
    ]
    yfov = 0.7
    lights = [{"type": "directional", "intensity": 4.0, "color": [1.0, 0.9, 0.8]}]
    _write(tmp_path / "f.gltf", nodes, [0, 1], [_perspective("eye", yfov, 0.1, 40.0)], lights)
    common = "[render]\nwidth = 64\nheight = 48\n" + SPHERE
    common += '[[objects]]\nshape = "mesh"\nfile = "f.gltf"\nmaterial = "m"\n'
    from_file = 'camera = { from_file = "eye" }\n' + common + "import_lights = true\n"
    toml = (
        f"camera = {{ position = [6.0, 1.0, 0.0], target = [5.0, 1.0, 0.0], "
        f"fov_y = {math.degrees(yfov)!r}, near = 0.1, far = 40.0 }}\n"
        + common
        + f'[[lights]]\ntype = "directional"\ncolor = [1.0, 0.9, 0.8]\n'
        f"intensity = {4.0 / math.pi!r}\ndirection = [0.0, -0.6, -0.8]\n"
    )
    images = []
    for text in (from_file, toml):
        r = Renderer(gl_egl, load_scene(_scene(tmp_path, text)))
        try:
            r.render()
            images.append(r.read_hdr())
        finally:
            r.release()
    assert np.count_nonzero(images[1][..., :3]) > 0.2 * images[1][..., :3].size
    np.testing.assert_array_equal(images[0], images[1])


def test_python_api_switches_to_a_file_camera_and_keeps_file_lights_once(
    tmp_path: Path, gl_egl: GLContext
) -> None:
    """``OffscreenRenderer.set_camera(from_file=...)`` moves to the file's camera (not the
    current position with the file's name on it), and a lights edit, which validates the
    whole scene again, keeps one copy of the imported lights."""
    from app.api import OffscreenRenderer

    nodes = [
        pygltflib.Node(name="eye", translation=[2.0, 1.0, 5.0], camera=0),
        _light_node("sun", 0, rotation=_quat("x", -45.0)),
    ]
    _write(tmp_path / "a.gltf", nodes, [0, 1], [_perspective("eye", 0.5, 0.1, 40.0)],
           [{"type": "directional", "intensity": 3.0}])  # fmt: skip
    # A camera of the scene's own: without one, a scene naming a mesh file is framed
    # (app/scene/model_file.py), and this file's hidden triangle lies 500 m below.
    text = (
        "[camera]\nposition = [0.0, 1.0, 6.0]\n"
        + SPHERE
        + '[[objects]]\nshape = "mesh"\nfile = "a.gltf"\nimport_lights = true\n'
    )
    with OffscreenRenderer(_scene(tmp_path, text), (32, 18), gl=gl_egl) as r:
        assert r.scene.camera.position == [0.0, 1.0, 6.0]
        r.set_camera(from_file="eye", exposure=0.5)
        cam = r.scene.camera
        assert cam.position == [2.0, 1.0, 5.0] and cam.exposure == 0.5
        assert cam.fov_y == pytest.approx(math.degrees(0.5))
        r.set_lights(environment=None)  # the lights as they are, validated again
        assert len(r.scene.lights) == 1
        r.set_camera(position=[0.0, 2.0, 6.0])  # an ordinary change of the file's camera
        assert r.scene.camera.fov_y == pytest.approx(math.degrees(0.5))


# ---- bad input ---------------------------------------------------------------------

MESH = '[[objects]]\nshape = "mesh"\nfile = "b.gltf"\n'


def _bad_file(tmp_path: Path) -> None:
    nodes = [
        pygltflib.Node(name="n0", translation=[0.0, 0.0, 5.0], camera=0),
        pygltflib.Node(name="n1", camera=1),
        _light_node("l", 0),
    ]
    cameras = [
        _perspective("Camera_0", 0.8, 0.1, 10.0),
        pygltflib.Camera(name="flat", type="orthographic",
                         orthographic=pygltflib.Orthographic(xmag=1, ymag=1, znear=0.1, zfar=9)),
    ]  # fmt: skip
    path = _write(tmp_path / "b.gltf", nodes, [0, 1, 2], cameras, [{"type": "point"}])
    _write(tmp_path / "nocam.gltf", [pygltflib.Node(name="x")], [0])
    _write(tmp_path / "nan.gltf", [_light_node("l", 0)], [0], lights=[{"type": "point",
           "intensity": 123.0}])  # fmt: skip
    nan = tmp_path / "nan.gltf"
    nan.write_text(nan.read_text().replace("123.0", "NaN"))
    cone = [{"type": "spot", "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.5}}]
    _write(tmp_path / "cone.gltf", [_light_node("l", 0)], [0], lights=cone)
    assert path.is_file()


BAD = [
    ("unknown-name", 'camera = { from_file = "Cam" }\n' + MESH, "camera.from_file",
     "no camera 'Cam' in the shown scene (cameras: cameras[0] 'Camera_0' on node 0 'n0'"),
    ("bad-index", "camera = { from_file = 7 }\n" + MESH, "camera.from_file",
     "camera 7 does not exist"),
    ("orthographic", 'camera = { from_file = "flat" }\n' + MESH, "camera.from_file",
     "'orthographic': the project has only perspective cameras"),
    ("no-cameras", 'camera = { from_file = "x" }\n' + MESH.replace("b.gltf", "nocam.gltf"),
     "camera.from_file", "the file has no cameras"),
    ("no-gltf-object", 'camera = { from_file = "x" }\n' + SPHERE, "camera.from_file",
     "no object of the scene is a glTF file"),
    ("two-gltf-objects", 'camera = { from_file = "n0" }\n' + MESH + MESH, "camera.object",
     "several objects are glTF files (objects[0], objects[1])"),
    ("unknown-object", 'camera = { from_file = "n0", object = "car" }\n' + MESH,
     "camera.object", "no object named 'car'"),
    ("aperture-no-focus", 'camera = { from_file = "n0", aperture = 0.1 }\n' + MESH,
     "camera.focus_distance", "give focus_distance (or target) with aperture"),
    ("object-alone", "camera = { object = 0 }\n" + MESH, "camera.object",
     "applies only with from_file"),
    ("nan-intensity", MESH.replace("b.gltf", "nan.gltf") + "import_lights = true\n",
     "objects[0].import_lights", "lights[0].intensity: must be a finite number"),
    ("inner-past-outer", MESH.replace("b.gltf", "cone.gltf") + "import_lights = true\n",
     "objects[0].import_lights", "innerConeAngle: must be less than outerConeAngle"),
    ("lights-on-sphere", SPHERE + "import_lights = true\n", "objects[1].import_lights",
     "needs a glTF file"),
    ("scale-alone", MESH + "light_scale = 2.0\n", "objects[0].light_scale",
     "applies only with import_lights"),
]  # fmt: skip


@pytest.mark.parametrize(("text", "key", "fragment"), [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_input_exits_2_naming_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, key: str, fragment: str
) -> None:
    """``pbs render`` exits 2 with one line naming the scene file, the key and (for a
    problem inside the glTF) the file and its JSON path; nothing is written."""
    _bad_file(tmp_path)
    scene = _scene(tmp_path, text)
    out = tmp_path / "out"
    out.mkdir()
    capsys.readouterr()
    rc = main(["render", str(scene), "-o", str(out / "x.png"), "--size", "16x16"])
    err = capsys.readouterr().err
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pbs: error: {scene}: {key}: "), lines[0]
    assert fragment in lines[0], lines[0]
    assert not any(out.iterdir())


# ---- fuzzed light and camera JSON --------------------------------------------------

JUNK = st.one_of(
    st.none(), st.booleans(), st.integers(-3, 3), st.text(max_size=3),
    st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 0.0, 1e300, 2.0, 1.6]),
    st.lists(st.floats(allow_nan=True), max_size=4), st.dictionaries(st.text(max_size=2),
    st.integers(), max_size=2),
)  # fmt: skip
LIGHT_KEYS = ["type", "color", "intensity", "range", "spot", "innerConeAngle", "outerConeAngle"]
CAMERA_KEYS = ["type", "yfov", "znear", "zfar", "perspective", "camera", "translation"]


def _edits(keys: list[str]) -> st.SearchStrategy:
    return st.lists(st.tuples(st.sampled_from(keys), JUNK), min_size=1, max_size=3)


FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip


@FUZZ
@given(edits=_edits([*LIGHT_KEYS, "light", "rotation"]))
def test_fuzzed_lights_load_or_fail_cleanly(tmp_path: Path, edits: list) -> None:
    """Wrong types, NaN, infinities and out-of-range values in the file's light and its
    node: the scene loads (every light finite) or raises one InputError naming the
    object's import_lights, never another exception."""
    _fuzz(tmp_path, edits, camera=False)


@FUZZ
@given(edits=_edits(CAMERA_KEYS))
def test_fuzzed_cameras_load_or_fail_cleanly(tmp_path: Path, edits: list) -> None:
    """The same for the file's camera and its node, through camera.from_file."""
    _fuzz(tmp_path, edits, camera=True)


def _fuzz(tmp_path: Path, edits: list, camera: bool) -> None:
    nodes = [
        pygltflib.Node(name="c", translation=[0.0, 1.0, 5.0], camera=0),
        _light_node("s", 0, rotation=_quat("x", -60.0)),
    ]
    light = {"type": "spot", "intensity": 5.0, "range": 9.0, "spot": {"outerConeAngle": 0.6}}
    path = _write(tmp_path / "z.gltf", nodes, [0, 1], [_perspective("c", 0.8, 0.1, 30.0)],
                  [light])  # fmt: skip
    data = json.loads(path.read_text())
    light, cam = data["extensions"][EXT]["lights"][0], data["cameras"][0]
    for key, value in edits:
        if camera and key in ("yfov", "znear", "zfar"):
            cam["perspective"][key] = value
        elif camera and key in ("type", "perspective"):
            cam[key] = value
        elif camera:  # the camera's node
            data["nodes"][0][key] = value
        elif key in ("innerConeAngle", "outerConeAngle"):
            if isinstance(light.setdefault("spot", {}), dict):
                light["spot"][key] = value
        elif key == "light":
            data["nodes"][1]["extensions"][EXT]["light"] = value
        elif key == "rotation":  # the light's node
            data["nodes"][1][key] = value
        else:
            light[key] = value
    path.write_text(json.dumps(data))  # NaN and Infinity as Python's json writes them
    text = MESH.replace("b.gltf", "z.gltf")
    text = 'camera = { from_file = "c" }\n' + text if camera else text + "import_lights = true\n"
    try:
        scene = load_scene(_scene(tmp_path, text)).scene
    except InputError as exc:
        assert exc.key == ("camera.from_file" if camera else "objects[0].import_lights")
        return
    values = [scene.camera.position, scene.camera.target, [scene.camera.fov_y]]
    values += [[*x.color, x.intensity, *(x.position or []), *(x.direction or [])]
               for x in scene.lights]  # fmt: skip
    assert all(math.isfinite(v) for row in values for v in row)


# ---- in the viewer -----------------------------------------------------------------


def test_viewer_orbits_a_file_camera_and_lists_file_lights(
    tmp_path: Path, xdisplay: str, gl_egl: GLContext
) -> None:
    """``pbs view`` on a scene with a file camera and file lights: the Lights panel draws
    (the imported lights are listed, not editable), an orbit moves the camera and keeps
    the file's field of view, and the window shows what ``pbs render`` renders."""
    from app.viewer.window import Viewer
    from tests.test_viewer import assert_close, headless, window_image

    nodes = [
        pygltflib.Node(name="eye", translation=[0.0, 1.0, 6.0], camera=0),
        _light_node("sun", 0, rotation=_quat("x", -45.0)),
    ]
    _write(tmp_path / "v.gltf", nodes, [0, 1], [_perspective("eye", 0.6, 0.1, 40.0)],
           [{"type": "directional", "intensity": 6.0}])  # fmt: skip
    text = 'camera = { from_file = "eye" }\n' + SPHERE
    text += '[[objects]]\nshape = "mesh"\nfile = "v.gltf"\nmaterial = "m"\nimport_lights = true\n'
    size = (160, 90)
    v = Viewer(_scene(tmp_path, text), size, vsync=False)
    try:
        v.panels.expand("Lights")
        v.settle()
        assert not v.state.error, v.state.error
        assert len(v.scene.lights) == 1
        v.orbit(40.0, 0.0)
        v.settle()
        assert not v.state.error, v.state.error
        cam = v.scene.camera
        assert cam.position != [0.0, 1.0, 6.0]
        assert cam.fov_y == pytest.approx(math.degrees(0.6))
        assert_close(window_image(v), headless(gl_egl, v.document.loaded, size))
    finally:
        v.close()


def test_bundled_stage_is_its_generator_output_and_loads() -> None:
    """scenes/meshes/stage.gltf is what ``python -m app.assets.gltf_stage`` writes, and
    scenes/gltf_stage.toml takes its camera (at the Camera node, fov 0.6 rad) and its
    three lights from it."""
    from app.assets.gltf_stage import OUT, build
    from app.resources import scenes_dir

    assert OUT.read_text(encoding="utf-8") == build()
    scene = load_scene(scenes_dir() / "gltf_stage.toml").scene
    assert scene.camera.position == [0.0, 2.2, 5.5]
    assert scene.camera.fov_y == pytest.approx(math.degrees(0.6))
    assert [x.type for x in scene.lights] == ["spot", "point", "directional"]


def test_huge_quaternion_is_normalised() -> None:
    """A finite quaternion of length ~1e154 overflowed the squared norm to infinity and the
    node was taken as unrotated; it is normalised without overflow now."""
    import pygltflib

    from app.scene.gltf_document import node_matrix

    turn = node_matrix(pygltflib.Node(rotation=[0.0, 0.0, 1.3e154, 1.3e154]), 0)
    assert np.allclose(turn[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
