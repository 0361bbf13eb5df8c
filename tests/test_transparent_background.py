"""``render.background = "transparent"`` (``pbs render --background transparent``, the API's
``set_settings(background=...)``, a job file's ``background``): an RGBA image whose alpha
is the antialiased coverage, straight alpha, edge colours not darkened. Real headless GL,
real shaders, real files (docs/architecture.md, "Alpha").
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.api import OffscreenRenderer
from app.cli import main

pytestmark = pytest.mark.gl

REPO = Path(__file__).resolve().parent.parent
W, H = 48, 36

# One sphere on a bright background colour (which must not leak into the image), its
# material black but emissive: every pixel it covers has the same radiance, so an edge
# pixel's straight colour must be the interior's, whatever its coverage. Antialiasing
# "none": the alpha is compared with the supersampled G-buffer's coverage (the
# antialiasing modes' alpha has a test of its own below).
SCENE = f"""
background = [0.9, 0.2, 0.6]
[render]
width = {W}
height = {H}
supersample = 2
background = "transparent"
antialiasing = "none"
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov_y = 40.0
[materials.glow]
base_color = [0.0, 0.0, 0.0]
roughness = 1.0
emissive = [0.6, 0.3, 0.1]
[[objects]]
shape = "sphere"
radius = 0.9
material = "glow"
[[lights]]
type = "directional"
direction = [0.0, 0.0, -1.0]
intensity = 0.0
"""


# An alpha-blended pane in front of the sphere, wider than it.
PANE = """
[materials.pane]
base_color = [0.0, 0.0, 0.0]
emissive = [0.2, 0.5, 0.9]
alpha = 0.4
alpha_mode = "blend"
[[objects]]
shape = "box"
size = [2.4, 0.5, 0.05]
position = [0.0, 0.0, 1.2]
material = "pane"
"""


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(SCENE, encoding="utf-8")
    return path


def _coverage(covered: np.ndarray, factor: int) -> np.ndarray:
    """The fraction of each output pixel's factor x factor G-buffer samples covered."""
    h, w = covered.shape[0] // factor, covered.shape[1] // factor
    return covered.reshape(h, factor, w, factor).mean(axis=(1, 3))


def test_alpha_is_the_supersampled_coverage(scene: Path) -> None:
    """Alpha 255 inside the sphere, 0 in empty space, and at the silhouette exactly the
    fraction of the 2 x 2 samples the G-buffer covered (to the nearest 8-bit step); the HDR
    image's alpha is that fraction in float."""
    with OffscreenRenderer(scene) as r:
        image = r.render()
        hdr = r.hdr()
        covered = r.channel("covered")
    assert image.shape == (H, W, 4) and image.dtype == np.uint8
    assert hdr.shape == (H, W, 4)
    coverage = _coverage(covered, 2)
    alpha = image[..., 3]
    assert alpha[H // 2, W // 2] == 255 and alpha[0, 0] == 0
    edge = (coverage > 0.0) & (coverage < 1.0)
    assert edge.sum() >= 20, "a sphere's silhouette has fractional pixels at 2 x 2"
    assert np.all((alpha[edge] > 0) & (alpha[edge] < 255))
    # within one step: how a GL rounds a half (0.5 x 255) to unorm8 is its own choice
    assert np.abs(alpha.astype(np.int32) - coverage * 255.0).max() <= 0.5 + 1e-6
    np.testing.assert_allclose(hdr[..., 3], coverage, atol=1e-6)
    assert np.all(hdr[coverage == 0.0] == 0.0), "the background colour leaked in"


def test_edge_colours_are_not_darkened(scene: Path) -> None:
    """The HDR image is premultiplied (an edge pixel's radiance is coverage x the
    interior's), and the display image straight: every pixel with alpha holds the
    interior's colour (within the 8-bit rounding), not a darker one."""
    with OffscreenRenderer(scene) as r:
        image = r.render().astype(np.int32)
        hdr = r.hdr()
    alpha = hdr[..., 3]
    interior = hdr[H // 2, W // 2, :3]
    edge = (alpha > 0.0) & (alpha < 1.0)
    np.testing.assert_allclose(hdr[edge][:, :3], alpha[edge][:, None] * interior, rtol=1e-5)
    inside = image[H // 2, W // 2, :3]
    assert inside.min() > 40, "the emissive colour shows"
    visible = image[..., 3] > 0
    assert np.abs(image[visible][:, :3] - inside).max() <= 1


def test_plain_frame_alpha_is_the_coverage(scene: Path) -> None:
    """Without supersampling (a frame that would fuse post into the lighting pass): alpha
    is 255 exactly where the G-buffer has a surface, 0 elsewhere."""
    with OffscreenRenderer(scene) as r:
        r.set_settings(supersample=1)
        image = r.render()
        covered = r.channel("covered")
    assert covered.any() and not covered.all()
    np.testing.assert_array_equal(image[..., 3], np.where(covered, 255, 0))


def test_depth_of_field_blurs_alpha_with_the_colour(scene: Path) -> None:
    """An out-of-focus sphere: the gather spreads coverage as it spreads radiance, so the
    blurred rim has fractional alpha and, every sample being the same emissive colour,
    the straight colour is still the interior's."""
    with OffscreenRenderer(scene) as r:
        r.set_settings(supersample=1)
        r.set_camera(aperture=0.4, focus_distance=12.0)
        image = r.render().astype(np.int32)
    alpha = image[..., 3]
    rim = (alpha > 0) & (alpha < 255)
    assert rim.sum() >= 40 and alpha[0, 0] == 0 and alpha[H // 2, W // 2] == 255
    inside = image[H // 2, W // 2, :3]
    assert np.abs(image[alpha >= 8][:, :3] - inside).max() <= 2


def test_blended_part_over_nothing_has_its_alpha(tmp_path: Path) -> None:
    """An alpha-blended pane (alpha 0.4) beside the sphere over empty space: its coverage
    is 0.4 (alpha composited "over" as colour is), 1 where it is over the sphere."""
    text = SCENE.replace("supersample = 2", "supersample = 1") + PANE
    path = tmp_path / "pane.toml"
    path.write_text(text, encoding="utf-8")
    with OffscreenRenderer(path) as r:
        image = r.render()
        covered = r.channel("covered")
    alpha = image[..., 3]
    row = alpha[H // 2]
    assert row[W // 2] == 255 and covered[H // 2, W // 2]
    beside = ~covered[H // 2] & (row > 0)
    assert beside.sum() >= 4, "the pane shows beside the sphere"
    assert np.all(np.abs(row[beside].astype(int) - 102) <= 1)  # 0.4 x 255
    assert alpha[0, 0] == 0


def test_opaque_stays_rgb_with_alpha_one(scene: Path) -> None:
    """The default background: a 3-channel image, alpha 255 everywhere, the background
    colour where nothing is."""
    with OffscreenRenderer(scene) as r:
        r.set_settings(background="opaque")
        image = r.render()
        rgba = r.renderer.read_rgba()
    assert image.shape == (H, W, 3)
    assert np.all(rgba[..., 3] == 255)
    assert image[0, 0].tolist() == rgba[0, 0, :3].tolist() and image[0, 0, 0] > 200


def test_environment_background_is_left_out(tmp_path: Path) -> None:
    """A scene that draws its environment behind the objects: transparent leaves those
    pixels empty (the environment still lights the objects)."""
    with OffscreenRenderer("ibl_studio", size=(W, H)) as r:
        opaque = r.render()
        r.set_settings(background="transparent", antialiasing="none")  # alpha 0 or 1
        image = r.render()
        covered = r.channel("covered")
    assert opaque[0, 0].max() > 0, "the opaque frame shows the environment"
    assert image.shape == (H, W, 4)
    np.testing.assert_array_equal(image[..., 3] == 255, covered)
    assert np.all(image[~covered] == 0)


def _pbs(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-m", "app", *argv],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_cli_writes_rgba_png_and_hdr_with_alpha(scene: Path, tmp_path: Path) -> None:
    """``--background transparent`` over a scene that says opaque: an RGBA PNG, and the
    HDR file's fourth channel the coverage (premultiplied RGB)."""
    text = scene.read_text(encoding="utf-8").replace('"transparent"', '"opaque"')
    scene.write_text(text, encoding="utf-8")
    out, npy, exr = tmp_path / "o.png", tmp_path / "o.npy", tmp_path / "o.exr"
    for hdr in (npy, exr):
        proc = _pbs("render", str(scene), "-o", str(out), "--hdr", str(hdr),
                    "--background", "transparent", "-q", cwd=tmp_path)  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout == "" and proc.stderr == ""
    with Image.open(out) as png:
        assert png.mode == "RGBA" and png.size == (W, H)
        alpha = np.asarray(png)[..., 3]
    assert alpha[0, 0] == 0 and alpha[H // 2, W // 2] == 255
    assert np.any((alpha > 0) & (alpha < 255))
    from_npy = np.load(npy)
    assert from_npy.shape == (H, W, 4)
    assert np.abs(from_npy[..., 3] * 255.0 - alpha).max() <= 0.5 + 1e-6
    import OpenEXR

    with OpenEXR.File(str(exr)) as f:
        np.testing.assert_array_equal(f.channels()["RGBA"].pixels, from_npy)


def test_cli_opaque_option_over_a_transparent_scene(scene: Path, tmp_path: Path) -> None:
    """``--background opaque`` over a scene that says transparent: an RGB PNG."""
    out = tmp_path / "o.png"
    assert main(["render", str(scene), "-o", str(out), "--background", "opaque", "-q"]) == 0
    with Image.open(out) as png:
        assert png.mode == "RGB"


def test_batch_job_writes_rgba(scene: Path, tmp_path: Path) -> None:
    """A job file's ``background = "transparent"`` over a scene that says opaque."""
    text = scene.read_text(encoding="utf-8").replace('"transparent"', '"opaque"')
    scene.write_text(text, encoding="utf-8")
    jobs = tmp_path / "jobs.toml"
    jobs.write_text(
        f'scene = "{scene.name}"\nbackground = "transparent"\norbit = {{ frames = 2 }}\n',
        encoding="utf-8",
    )
    out = tmp_path / "out"
    assert main(["batch", str(jobs), "-o", str(out), "-q"]) == 0
    for name in ("frame-0000.png", "frame-0001.png"):
        with Image.open(out / name) as png:
            assert png.mode == "RGBA"
            alpha = np.asarray(png)[..., 3]
        assert alpha[0, 0] == 0 and alpha[H // 2, W // 2] == 255


@pytest.mark.parametrize(
    ("where", "expected"),
    [
        ("option", "--background"),
        ("scene", "render.background"),
        ("job", "background"),
    ],
)
def test_bad_background_is_one_line_exit_2(
    scene: Path, tmp_path: Path, where: str, expected: str
) -> None:
    """A background other than opaque or transparent: exit 2, one line naming the file
    (or option) and the key, no output written."""
    out = tmp_path / "out.png"
    if where == "option":
        argv = ["render", str(scene), "-o", str(out), "--background", "pink"]
    elif where == "scene":
        text = scene.read_text(encoding="utf-8").replace('"transparent"', '"pink"')
        scene.write_text(text, encoding="utf-8")
        argv = ["render", str(scene), "-o", str(out)]
    else:
        jobs = tmp_path / "jobs.toml"
        jobs.write_text(
            f'scene = "{scene.name}"\nbackground = "pink"\norbit = {{ frames = 1 }}\n',
            encoding="utf-8",
        )
        out = tmp_path / "out"
        argv = ["batch", str(jobs), "-o", str(out)]
    proc = _pbs(*argv, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert expected in lines[0] and "pink" in lines[0]
    if where != "option":
        assert str(scene if where == "scene" else tmp_path / "jobs.toml") in lines[0]
    assert not out.exists()


@pytest.mark.parametrize("mode", ["fxaa", "jitter", "sraa", "gbaa"])
def test_antialiased_alpha_is_fractional_and_edges_keep_their_colour(
    scene: Path, mode: str
) -> None:
    """Under each antialiasing mode without supersampling, the silhouette's alpha takes
    values between 0 and 1 (the antialiased coverage) while the straight colour of every
    pixel with alpha >= 0.25 stays the sphere's own: neither FXAA nor the jittered mean
    mixes in the black of the empty pixels, nor does the subpixel reconstruction."""
    text = scene.read_text(encoding="utf-8")
    text = text.replace("supersample = 2", "supersample = 1")
    scene.write_text(text.replace('antialiasing = "none"', f'antialiasing = "{mode}"'))
    with OffscreenRenderer(scene) as r:
        rgba = r.render()
    alpha = rgba[..., 3].astype(np.int32)
    partial = (alpha > 0) & (alpha < 255)
    assert partial.sum() >= 20, f"{mode}: {partial.sum()} fractional alpha pixels"
    interior = rgba[alpha == 255][:, :3].astype(np.int32)
    colour = np.median(interior, axis=0)
    visible = alpha >= 64
    worst = np.abs(rgba[visible][:, :3].astype(np.int32) - colour).max()
    assert worst <= 3, f"{mode}: an edge colour is {worst} codes off the sphere's {colour}"
