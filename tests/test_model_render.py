"""A model file rendered without a scene file (``pbs render MODEL``, ``OffscreenRenderer(
"model.glb")``): framed by the camera, lit by the default look, views that differ, and bad
input refused in one line (app/scene/model_file.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from app.api import OffscreenRenderer
from app.scene.loader import load_scene
from app.scene.model_file import Look
from app.scene.sources import scene_from

pytestmark = pytest.mark.gl

REPO = Path(__file__).resolve().parent.parent
MESHES = REPO / "scenes" / "meshes"
W, H = 160, 120
SIZE = f"{W}x{H}"
BUNDLED = ("material_sampler.glb", "stage.gltf", "teapot.obj")


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An STL (a box on a capsule, off the origin) and a PLY (a torus-like annulus) that
    the test writes with trimesh."""
    folder = tmp_path_factory.mktemp("models")
    box = trimesh.creation.box((1.0, 0.5, 2.0))
    capsule = trimesh.creation.capsule(height=1.0, radius=0.3)
    capsule.apply_translation((0.0, 1.0, 0.0))
    stl = trimesh.util.concatenate([box, capsule])
    stl.apply_translation((5.0, -2.0, 3.0))  # the framing must follow the model
    stl.export(folder / "part.stl")
    ply = trimesh.creation.annulus(r_min=0.5, r_max=1.0, height=0.3)
    ply.apply_scale(30.0)  # centimetres: the framing must follow the size too
    ply.export(folder / "ring.ply")
    return folder


def _models(made: Path) -> list[Path]:
    return [MESHES / name for name in BUNDLED] + [made / "part.stl", made / "ring.ply"]


MODEL_IDS = [*BUNDLED, "part.stl", "ring.ply"]


def _model(made: Path, name: str) -> Path:
    return next(p for p in _models(made) if p.name == name)


def _app(*argv: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, "-m", "app", *map(str, argv)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )


def _png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.size == (W, H)
        return np.asarray(image.convert("RGB"), np.float64)


def _luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def _check_framed_and_lit(covered: np.ndarray, image: np.ndarray, what: str) -> None:
    """The model covers a sane share of the image around its centre, and its pixels are
    lit, not black and not flat."""
    share = float(covered.mean())
    assert 0.15 <= share <= 0.85, f"{what}: the model covers {share:.0%} of the image"
    rows, cols = np.nonzero(covered)
    centre_x = (cols.min() + cols.max()) / 2.0 / (W - 1)
    centre_y = (rows.min() + rows.max()) / 2.0 / (H - 1)
    assert abs(centre_x - 0.5) < 0.12 and abs(centre_y - 0.5) < 0.12, (
        f"{what}: the model's box is centred at ({centre_x:.2f}, {centre_y:.2f})"
    )
    lum = _luminance(image[covered])
    assert lum.mean() > 25.0, f"{what}: the model is dark (mean {lum.mean():.1f} of 255)"
    assert np.percentile(lum, 90) - np.percentile(lum, 10) > 20.0, f"{what}: flat lighting"


@pytest.mark.parametrize("name", MODEL_IDS)
def test_cli_renders_a_model_file_framed_and_lit(made: Path, tmp_path: Path, name: str) -> None:
    model = _model(made, name)
    out, depth = tmp_path / "out.png", tmp_path / "depth.png"
    proc = _app("render", model, "-o", out, "--size", SIZE, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = _app("render", model, "-o", depth, "--size", SIZE, "--debug", "depth", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    covered = _png(depth).max(axis=2) > 0.0  # the depth view leaves empty pixels black
    _check_framed_and_lit(covered, _png(out), name)


@pytest.mark.parametrize("name", MODEL_IDS)
def test_api_renders_a_model_file_framed_and_lit(made: Path, name: str) -> None:
    with OffscreenRenderer(_model(made, name), size=(W, H)) as r:
        r.render()
        covered = r.depth() > 0.0
        image = r.ldr().astype(np.float64)
    _check_framed_and_lit(covered, image, name)


def test_views_change_the_image(tmp_path: Path) -> None:
    """Every named view and an explicit azimuth give another image of the teapot."""
    images = {}
    for view in ("front", "side", "top", "iso"):
        with OffscreenRenderer(MESHES / "teapot.obj", (W, H), look=Look(view=view)) as r:
            r.render()
            images[view] = r.ldr().astype(np.float64)
    with OffscreenRenderer(MESHES / "teapot.obj", (W, H), look=Look(azimuth=200.0)) as r:
        r.render()
        images["azimuth"] = r.ldr().astype(np.float64)
    names = list(images)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            diff = np.abs(images[a] - images[b]).mean()
            assert diff > 3.0, f"--view {a} and {b} differ by only {diff:.2f}"
    # and through the CLI
    for view in ("front", "top"):
        proc = _app("render", MESHES / "teapot.obj", "-o", tmp_path / f"{view}.png",
                    "--size", SIZE, "--view", view, cwd=tmp_path)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
    diff = np.abs(_png(tmp_path / "front.png") - _png(tmp_path / "top.png")).mean()
    assert diff > 3.0


def test_sky_environment_and_file_camera(tmp_path: Path) -> None:
    """--env sky lights the model as sanely as the studio; --camera file takes the glTF
    file's camera (stage.gltf's looks at the floor from its own place)."""
    out = tmp_path / "sky.png"
    proc = _app("render", MESHES / "teapot.obj", "-o", out, "--size", SIZE, "--env", "sky",
                cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lum = _luminance(_png(out))
    assert 20.0 < lum.mean() < 230.0
    framed = scene_from(MESHES / "stage.gltf", size=(W, H)).scene.camera
    own = scene_from(MESHES / "stage.gltf", look=Look(camera="file"), size=(W, H)).scene.camera
    assert own.position != framed.position


BAD = {  # name, content (None: no file), what the one line says
    "unsupported suffix": ("model.fbx", b"Kaydara FBX Binary", "unsupported file type '.fbx'"),
    "missing file": ("missing.obj", None, "missing.obj: no such file"),
    "malformed glb": ("broken.glb", b"glTF\x02\x00\x00\x00not a glb", "not a glTF 2.0 file"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_model_input_is_one_line_and_exit_2(tmp_path: Path, case: str) -> None:
    name, content, says = BAD[case]
    if content is not None:
        (tmp_path / name).write_bytes(content)
    out = tmp_path / "out.png"
    proc = _app("render", name, "-o", out, "--size", SIZE, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"pbs: error: {name}: "), lines
    assert says in lines[0] and "objects[" not in lines[0], lines  # no key the user never wrote
    assert not out.exists()


def test_bad_env_and_file_camera_are_one_line(tmp_path: Path) -> None:
    for argv, option in (
        (("--env", "nowhere.hdr"), "--env"),
        (("--camera", "file"), "--camera"),  # material_sampler.glb holds no camera
    ):
        out = tmp_path / "out.png"
        model = MESHES / "material_sampler.glb"
        proc = _app("render", model, "-o", out, "--size", SIZE, *argv, cwd=tmp_path)
        assert proc.returncode == 2
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and option in lines[0], lines
        assert not out.exists()


def test_scene_file_with_a_mesh_and_no_camera_or_light(tmp_path: Path) -> None:
    """A scene file naming only a mesh gets the defaults and one note, not a black image."""
    (tmp_path / "teapot.obj").write_bytes((MESHES / "teapot.obj").read_bytes())
    (tmp_path / "only.toml").write_text('[[objects]]\nshape = "mesh"\nfile = "teapot.obj"\n')
    _check_defaults_with_one_note(tmp_path, "only.toml", "only.toml")


def _check_defaults_with_one_note(tmp_path: Path, scene: str, note: str) -> None:
    """``scene`` (in ``tmp_path``) renders with exit 0 and one note holding ``note``, its
    object framed (the depth view's covered share) and lit (the image not flat)."""
    out, depth = tmp_path / "out.png", tmp_path / "depth.png"
    proc = _app("render", scene, "-o", out, "--size", SIZE, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if line.startswith("pbs: note:")]
    assert len(notes) == 1 and note in notes[0], proc.stderr
    proc = _app("render", scene, "-o", depth, "--size", SIZE, "--debug", "depth", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    _check_framed_and_lit(_png(depth).max(axis=2) > 0.0, _png(out), scene)


def test_a_scene_file_with_a_camera_and_no_light_is_metered(tmp_path: Path) -> None:
    """A scene file naming a mesh and a camera but no light gets the default look at the
    exposure metered for the asset, as one without a camera does (at the camera's default
    0 EV the white teapot under the studio and key light is blown out); an exposure the
    scene writes is kept."""
    (tmp_path / "teapot.obj").write_bytes((MESHES / "teapot.obj").read_bytes())
    mesh = '[[objects]]\nshape = "mesh"\nfile = "teapot.obj"\n'
    camera = "[camera]\nposition = [0.0, 2.0, 6.0]\ntarget = [0.0, 0.5, 0.0]\n"
    (tmp_path / "framed.toml").write_text(mesh)
    (tmp_path / "camera.toml").write_text(camera + mesh)
    (tmp_path / "exposed.toml").write_text(camera + "exposure = 0.5\n" + mesh)
    metered = scene_from(tmp_path / "framed.toml").scene
    given = scene_from(tmp_path / "camera.toml").scene
    assert list(given.camera.position) == [0.0, 2.0, 6.0] and len(given.lights) == 2
    assert given.camera.exposure == pytest.approx(metered.camera.exposure)
    assert given.camera.exposure < -2.0  # the white teapot: about -2 EV
    assert given.background == pytest.approx(metered.background)  # the same light grey
    from app.scene.model_file import backdrop_radiance

    exposed = scene_from(tmp_path / "exposed.toml").scene
    assert exposed.camera.exposure == 0.5 and list(exposed.camera.position) == [0.0, 2.0, 6.0]
    assert [light.model_dump() for light in exposed.lights] == [
        light.model_dump() for light in given.lights
    ]  # the same key and fill lights, whatever the exposure
    # the backdrop for the exposure the scene gives: the same grey on screen
    assert exposed.background == pytest.approx([backdrop_radiance(0.5, exposed.render.tonemap)] * 3)


@pytest.mark.parametrize("size", [(320, 240), (1280, 720)])
def test_a_scene_file_naming_only_a_mesh_is_framed_for_the_output_size(
    tmp_path: Path, size: tuple[int, int]
) -> None:
    """The default camera of a scene file naming only a mesh frames it for the size the
    image is drawn at (``--size``), as a model file's does: every point of the model
    projects inside the image at 320x240 as at the scene's own 16:9 (framed for 16:9, a
    4:3 image cuts the model at its left and right edges)."""
    from app.frame.camera import projection_matrix, view_matrix
    from app.scene.geometry import build_parts

    (tmp_path / "teapot.obj").write_bytes((MESHES / "teapot.obj").read_bytes())
    (tmp_path / "only.toml").write_text('[[objects]]\nshape = "mesh"\nfile = "teapot.obj"\n')
    loaded = scene_from(tmp_path / "only.toml", size=size)
    cam = loaded.scene.camera
    world = np.concatenate(
        [p.surface_points() @ p.model[:3, :3].T + p.model[:3, 3] for p in build_parts(loaded)]
    )
    clip = (
        np.c_[world, np.ones(len(world))]
        @ (projection_matrix(cam, size[0] / size[1]) @ view_matrix(cam)).T
    )
    ndc = clip[:, :2] / clip[:, 3:]
    assert np.all(clip[:, 3] > 0.0)
    extent = np.abs(ndc).max(axis=0)
    assert extent.max() <= 1.0, f"the model reaches {extent} of the half image (x, y)"
    assert extent.max() >= 0.5, f"the model fills only {extent} of the half image (x, y)"


def test_bundled_scenes_keep_their_camera_and_lights() -> None:
    """The defaults touch no bundled scene: each gives its camera and lights."""
    for path in sorted((REPO / "scenes").glob("*.toml")):
        assert scene_from(path).scene == load_scene(path).scene, path.name


PRIMITIVE = '[materials.red]\nbase_color = [0.8, 0.1, 0.1]\n\n[[objects]]\nshape = "sphere"\n'


def test_a_scene_of_primitives_with_no_light_gets_the_defaults(tmp_path: Path) -> None:
    """A scene of one sphere and nothing that lights it is framed and lit as a mesh's,
    with one note (it wrote an all-black image); with a camera it keeps the camera and
    gets the light and metered exposure."""
    (tmp_path / "ball.toml").write_text(PRIMITIVE + 'material = "red"\n')
    _check_defaults_with_one_note(tmp_path, "ball.toml", "ball.toml: gives no camera or light")
    camera = "[camera]\nposition = [0.0, 1.0, 9.0]\n"
    (tmp_path / "seen.toml").write_text(camera + PRIMITIVE + 'material = "red"\n')
    seen = scene_from(tmp_path / "seen.toml").scene
    assert list(seen.camera.position) == [0.0, 1.0, 9.0] and len(seen.lights) == 2
    assert seen.environment is not None and seen.camera.exposure < -1.0


@pytest.mark.parametrize(
    "lead, material",
    [
        ("lights = []\n", 'material = "red"\n'),  # unlit on purpose
        ("[materials.lamp]\nemissive = [1.0, 0.5, 0.2]\n", 'material = "lamp"\n'),
        ('[environment]\nsource = "uniform"\n', 'material = "red"\n'),
    ],
    ids=["opted-out", "emissive", "environment"],
)
def test_a_scene_that_chose_its_light_keeps_it(tmp_path: Path, lead: str, material: str) -> None:
    """A scene that writes ``lights = []``, lights itself by an emissive material of its
    own, or gives an environment is left as written (no camera framed, no light added)."""
    (tmp_path / "own.toml").write_text(lead + PRIMITIVE + material)
    assert scene_from(tmp_path / "own.toml").scene == load_scene(tmp_path / "own.toml").scene


@pytest.mark.viewer
def test_viewer_opens_a_model_file(xdisplay: str, tmp_path: Path) -> None:
    """``pbs view MODEL``'s document: the model's framed, lit scene, saved beside it."""
    from app.scene.model_file import model_document
    from app.untrusted.policy import InputPolicy
    from app.viewer.window import Viewer

    model = tmp_path / "teapot.obj"
    model.write_bytes((MESHES / "teapot.obj").read_bytes())
    (tmp_path / "teapot.toml").write_text("# someone's own scene: not to be overwritten\n")
    target, data = model_document(model, InputPolicy(), size=(W, H))
    assert target == tmp_path / "teapot-2.toml" and not target.exists()
    v = Viewer(target, (W, H), vsync=False, ui=False, data=data)
    try:
        v.settle()
        assert v.document.scene.lights and v.document.scene.environment is not None
        image = v.read_window().astype(np.float64)
        assert _luminance(image).std() > 10.0  # the teapot lit against the backdrop
    finally:
        v.close()


def test_env_image_from_another_folder(tmp_path: Path) -> None:
    """--env FILE.exr lights the model from an image outside the model's folder (the
    folder the option names is allowed too) and changes the image from the studio's."""
    (tmp_path / "envs").mkdir()
    (tmp_path / "model").mkdir()
    env = tmp_path / "envs" / "room.exr"
    env.write_bytes((REPO / "scenes" / "textures" / "window_room.exr").read_bytes())
    model = tmp_path / "model" / "teapot.obj"
    model.write_bytes((MESHES / "teapot.obj").read_bytes())
    outs = {}
    for name, argv in (("studio", ()), ("image", ("--env", env))):
        outs[name] = tmp_path / f"{name}.png"
        proc = _app("render", model, "-o", outs[name], "--size", SIZE, *argv, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
    image = _png(outs["image"])
    assert 20.0 < _luminance(image).mean() < 230.0
    assert np.abs(image - _png(outs["studio"])).mean() > 3.0


def test_look_options_on_a_scene_with_camera_and_lights_are_refused(tmp_path: Path) -> None:
    """--view on a scene that gives its own camera and lights would do nothing: one line."""
    out = tmp_path / "out.png"
    proc = _app("render", "teapot", "-o", out, "--size", SIZE, "--view", "top", cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "teapot.toml" in lines[0] and "gives its own camera" in lines[0]
    assert not out.exists()


def _lamp(folder: Path, intensity: float) -> Path:
    """A glTF box with one KHR_lights_punctual point light of ``intensity`` candela in
    front of it and above (trimesh writes the box; the light is added to its JSON)."""
    import pygltflib

    glb = folder / "box.glb"
    trimesh.creation.box((1.0, 1.0, 1.0)).export(glb)
    doc = pygltflib.GLTF2().load(str(glb))
    doc.extensions = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.9, 0.8], "intensity": intensity}
    ]}}  # fmt: skip
    doc.extensionsUsed = [*(doc.extensionsUsed or []), "KHR_lights_punctual"]
    light = pygltflib.Node(translation=[1.0, 2.0, 2.0], extensions={"KHR_lights_punctual": {
        "light": 0}})  # fmt: skip
    doc.nodes.append(light)
    doc.scenes[doc.scene or 0].nodes.append(len(doc.nodes) - 1)
    path = folder / f"lamp-{intensity:g}.glb"
    doc.save(str(path))
    return path


def test_a_file_with_lights_is_lit_by_them(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A glTF file's own KHR_lights_punctual light replaces the key light (the studio
    stays), one note says so, the exposure follows how bright the light is, and the box
    renders lit by it."""
    dim, bright = _lamp(tmp_path, 10.0), _lamp(tmp_path, 160.0)
    with caplog.at_level("WARNING", logger="pbs.scene"):
        scene = scene_from(dim, size=(W, H)).scene
    notes = [r.getMessage() for r in caplog.records if "KHR_lights_punctual" in r.getMessage()]
    assert len(notes) == 1 and dim.name in notes[0], notes
    assert [light.type for light in scene.lights] == ["point"]  # no key spot light
    assert scene.environment is not None and scene.environment.source == "studio"
    brighter = scene_from(bright, size=(W, H)).scene.camera.exposure
    assert scene.camera.exposure - brighter > 1.0, (scene.camera.exposure, brighter)
    with OffscreenRenderer(dim, size=(W, H)) as r:
        r.render()
        covered = r.depth() > 0.0
        image = r.ldr().astype(np.float64)
    _check_framed_and_lit(covered, image, dim.name)


def test_backdrop_is_one_light_grey_whatever_the_exposure() -> None:
    """Under the studio the pixels off the model are the light neutral backdrop, the same
    grey for models whose metered exposures differ (the white teapot, the colours)."""
    from app.scene.model_file import BACKDROP
    from tests.test_real_assets import clear_of

    exposures = []
    for model in (MESHES / "teapot.obj", MESHES / "material_sampler.glb"):
        with OffscreenRenderer(model, size=(W, H)) as r:
            r.render()
            off = clear_of(r.depth() > 0.0)  # off the model, not at its antialiased edge
            background = r.ldr()[..., :3][off].astype(np.float64)
            exposures.append(r.scene.camera.exposure)
        assert np.all(np.abs(background - 255.0 * BACKDROP) <= 2.0), model.name
    assert abs(exposures[0] - exposures[1]) > 0.2, exposures


@pytest.mark.parametrize("tonemap", ["linear", "neutral", "aces", "reinhard"])
def test_backdrop_radiance_inverts_the_post_pass(tonemap: str) -> None:
    """The backdrop's radiance shows as BACKDROP through the post pass's twin at every
    exposure the metering may choose, under every tone map."""
    from app.reference.tonemap import post_process
    from app.scene.model_file import BACKDROP, backdrop_radiance

    for exposure in (-8.0, -2.0, -0.7, 0.0, 3.0):
        radiance = backdrop_radiance(exposure, tonemap)
        shown = post_process(np.full(3, radiance), exposure, tonemap)
        assert np.allclose(shown, BACKDROP, atol=1e-9), (exposure, shown)


@pytest.mark.parametrize("size", [(160, 120), (256, 256), (480, 480), (512, 512), (400, 300)])
def test_the_key_lights_shadow_map_is_sized_for_the_image(size: tuple[int, int]) -> None:
    """The key light's shadow map follows the image (``key_shadow_resolution``): below the
    scene default's 2048 for a small image, yet with at least one texel for each pixel
    across the model (its bounding sphere, seen from the light in the map and from the
    camera in the image), as the default look's 1280x720 image has with a 2048 map."""
    import math

    from app.scene.geometry import build_parts
    from app.scene.model_file import _sphere, _surface_points

    def texels_per_pixel(size: tuple[int, int]) -> tuple[int, float]:
        loaded = scene_from(MESHES / "teapot.obj", size=size)
        key = next(light for light in loaded.scene.lights if light.type == "spot")
        centre, radius = _sphere(_surface_points(build_parts(loaded)))
        cam = loaded.scene.camera

        def across(eye: list[float], half_angle: float) -> float:  # of the field's side
            distance = float(np.linalg.norm(np.asarray(eye) - centre))
            return math.tan(math.asin(radius / distance)) / math.tan(math.radians(half_angle))

        texels = key.shadow_resolution * across(key.position, key.outer_angle)
        pixels = size[1] * across(cam.position, cam.fov_y / 2.0)
        return key.shadow_resolution, texels / pixels

    resolution, ratio = texels_per_pixel(size)
    assert resolution < 2048, f"{size}: a {resolution} map"
    assert ratio >= 1.0, f"{size}: {ratio:.2f} texels a pixel across the model"
    default, default_ratio = texels_per_pixel((1280, 720))
    assert default == 2048 and ratio >= default_ratio
