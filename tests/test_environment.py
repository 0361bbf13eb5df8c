"""Environment sources (app/textures/environment.py; docs/ibl.md): the HDR readers on
files the tests write, the Preetham sky against its formulas, the studio, the map's
direction convention, bad input as exit-2 errors, and image environments as lights."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.errors import InputError
from app.frame.lights import cell_integrals, fibonacci_sphere, map_lights, uniform_environment
from app.reference.environment import texel_directions
from app.reference.tonemap import post_process
from app.scene import model_file
from app.scene.loader import load_scene
from app.textures import environment as envmod
from app.textures.environment import (
    lookup,
    preetham_sky,
    read_exr,
    read_hdr,
    studio,
    zenith_xyY,
)


def encode_rgbe(rgb: np.ndarray) -> np.ndarray:
    """Float RGB -> RGBE bytes, Ward's float2rgbe: e = frexp exponent of the largest
    channel, m = c * 256 / 2^e (written independently of the reader)."""
    peak = rgb.max(axis=-1)
    _mant, exp = np.frexp(peak)
    scale = np.where(peak < 1e-32, 0.0, 256.0 / np.ldexp(1.0, exp))
    out = np.zeros((*rgb.shape[:-1], 4), np.uint8)
    out[..., :3] = np.floor(rgb * scale[..., None]).clip(0, 255).astype(np.uint8)
    out[..., 3] = np.where(peak < 1e-32, 0, exp + 128).astype(np.uint8)
    return out


def write_hdr(path: Path, rgb: np.ndarray, rle: bool) -> None:
    """A Radiance file: flat pixels, or the new run-length scanlines (runs and literals)."""
    h, w = rgb.shape[:2]
    px = encode_rgbe(rgb)
    body = bytearray()
    for row in px:
        if not rle:
            body += row.tobytes()
            continue
        body += bytes([2, 2, w >> 8, w & 255])
        for c in range(4):
            values, x = row[:, c], 0
            while x < w:
                run = 1
                while x + run < w and run < 127 and values[x + run] == values[x]:
                    run += 1
                if run >= 3:
                    body += bytes([128 + run, values[x]])
                    x += run
                else:
                    n = min(w - x, 128, 2)
                    body += bytes([n]) + values[x : x + n].tobytes()
                    x += n
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode()
    path.write_bytes(header + bytes(body))


@pytest.mark.parametrize("rle", [False, True])
def test_hdr_round_trip(tmp_path: Path, rle: bool) -> None:
    rng = np.random.default_rng(1)
    rgb = rng.uniform(0.0, 50.0, (6, 12, 3))
    rgb[0, :4] = 0.0  # e = 0: black
    rgb[1, :] = [3.0, 0.5, 0.25]  # one long run per channel
    path = tmp_path / "x.hdr"
    write_hdr(path, rgb, rle)
    got = read_hdr(path)
    assert got.shape == (6, 12, 3) and got.dtype == np.float32
    assert np.all(got[0, :4] == 0.0)
    # RGBE keeps 8 mantissa bits of the largest channel: error <= 1 step of it
    step = np.ldexp(1.0, np.frexp(rgb.max(axis=-1))[1] - 8)[..., None]
    assert np.all(np.abs(got - rgb) <= step)


def test_exr_round_trip(tmp_path: Path) -> None:
    import OpenEXR

    rgb = np.random.default_rng(2).uniform(0.0, 1e3, (4, 8, 3)).astype(np.float32)
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": rgb}) as f:
        f.write(str(tmp_path / "x.exr"))
    assert np.array_equal(read_exr(tmp_path / "x.exr"), rgb)


def test_texel_directions_convention() -> None:
    d, omega = texel_directions(64, 128)
    assert math.isclose(omega.sum(), 4.0 * math.pi, rel_tol=1e-12)
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    assert d[0, 64, 1] > 0.99  # row 0 is up
    assert np.allclose(d[32, 64], [0.0, 0.0, -1.0], atol=0.05)  # centre column: -Z
    assert d[32, 96, 0] > 0.99  # three quarters across: +X
    env = np.zeros((64, 128, 3), np.float32)
    env[32, 96] = 1.0
    assert lookup(env, np.array([1.0, 0.0, 0.0]))[0] == 1.0
    # turning the environment 90 degrees about +Y moves +X to -Z
    assert lookup(env, np.array([0.0, 0.0, -1.0]), rotation=90.0)[0] == 1.0


def test_preetham_zenith_and_sun() -> None:
    sun = np.array([0.0, math.cos(math.radians(50.0)), -math.sin(math.radians(50.0))])
    sky = preetham_sky(sun, 3.0, width=128)
    # The zenith texels carry the paper's zenith luminance (F / F(0, theta_s) = 1 there):
    # Y = 0.2126 R + 0.7152 G + 0.0722 B recovers it from linear sRGB.
    x, y, big_y = zenith_xyY(3.0, math.radians(50.0))
    assert 0.2 < x < 0.35 and 0.2 < y < 0.35 and 1.0 < big_y < 20.0
    lum = sky @ np.array([0.2126, 0.7152, 0.0722])
    top = lookup(sky, np.array([0.0, 1.0, 0.0]))
    assert math.isclose(float(top @ [0.2126, 0.7152, 0.0722]), big_y, rel_tol=0.03)
    # brighter around the sun than opposite it at the same height (circumsolar region)
    near = lookup(sky, sun * 0.9 + np.array([0.0, 0.1, 0.0]))
    away = lookup(sky, np.array([0.0, sun[1], -sun[2]]))
    assert near.sum() > 2.0 * away.sum()
    # blue overhead
    assert top[2] > top[0]
    # the ground is uniform and darker than the sky's mean
    d, _ = texel_directions(*sky.shape[:2])
    ground = lum[d[..., 1] < 0]
    assert np.ptp(ground) == 0.0 and ground[0] < lum[d[..., 1] > 0].mean()
    assert np.all(np.isfinite(sky)) and sky.min() >= 0.0


def test_preetham_turbidity_whitens_and_brightens_zenith() -> None:
    """Haze (higher turbidity) brightens the zenith (Y_z grows with T) and whitens it."""
    sun = np.array([0.0, 0.8, -0.6])
    up = np.array([0.0, 1.0, 0.0])
    clear = lookup(preetham_sky(sun, 2.0, width=64), up)
    hazy = lookup(preetham_sky(sun, 8.0, width=64), up)
    assert hazy.sum() > clear.sum()
    assert hazy[2] / hazy[0] < clear[2] / clear[0]


def test_studio_boxes() -> None:
    s = studio(width=256)
    assert s.min() == pytest.approx(envmod.FLOOR)
    az, el = (math.radians(a) for a in envmod.STUDIO_BOXES[0][:2])
    key = np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])
    assert lookup(s, key)[0] == pytest.approx(envmod.STUDIO_BOXES[0][4])
    assert lookup(s, np.array([0.0, -1.0, 0.0]))[0] == pytest.approx(envmod.FLOOR)
    # between the boxes: the walls, brighter than the floor, brightening upwards
    low, high = (lookup(s, np.array([math.cos(a), math.sin(a), 0.0]))[0] for a in (0.1, 0.6))
    assert envmod.FLOOR < low < high < envmod.CEILING


def test_studio_mean_is_the_default_looks_constant() -> None:
    """The default look meters other environments against the studio's mean radiance."""
    assert float(np.mean(studio())) == pytest.approx(model_file.STUDIO_MEAN, rel=0.01)


def test_mirror_sphere_reads_the_studio() -> None:
    """A mirror-smooth white metal sphere seen by the default look's camera (on +Z, the
    studio turned by STUDIO_TURN, the default exposure and tone map) reflects a readable
    room: its mean display value is well above black and its brightest texels (the soft
    boxes) are near white, so metals show both the room and highlights."""
    n = 256
    y, x = np.mgrid[-1 : 1 : n * 1j, -1 : 1 : n * 1j]
    disc = x * x + y * y < 1.0
    normal = np.stack([x[disc], -y[disc], np.sqrt(1.0 - x[disc] ** 2 - y[disc] ** 2)], -1)
    view = np.array([0.0, 0.0, 1.0])  # towards the camera
    reflected = 2.0 * (normal @ view)[:, None] * normal - view
    radiance = lookup(studio(), reflected, model_file.STUDIO_TURN)
    display = post_process(radiance, model_file.EXPOSURE, "neutral")[..., 0]
    # measured: mean 0.35, median 0.35 (a dark studio, a 0.03 backdrop: 0.06 and 0.009)
    assert display.mean() > 0.25 and np.median(display) > 0.25, display.mean()
    assert np.percentile(display, 99) > 0.9


def test_cell_integrals_partition_the_sphere() -> None:
    sky = preetham_sky(np.array([0.3, 0.5, -0.8]), 4.0, width=128)
    _d, omega = texel_directions(*sky.shape[:2])
    total = np.einsum("hw,hwc->c", omega, sky.astype(np.float64))
    cells = cell_integrals(sky, fibonacci_sphere(64), rotation=30.0)
    assert np.allclose(cells.sum(axis=0), total, rtol=1e-9)
    uniform = cell_integrals(np.ones((64, 128, 3), np.float32), fibonacci_sphere(64), 0.0)
    assert np.allclose(uniform, 4.0 * math.pi / 64, rtol=0.1)  # equal-area cells


def scene_with(tmp_path: Path, env: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(f"[environment]\n{env}\n")
    return path


def test_image_environment_lights(tmp_path: Path) -> None:
    rgb = np.full((16, 32, 3), 2.0)
    write_hdr(tmp_path / "grey.hdr", rgb, rle=True)
    loaded = load_scene(
        scene_with(tmp_path, 'source = "image"\nfile = "grey.hdr"\nintensity = 0.5')
    )
    assert Path(loaded.scene.environment.file).is_absolute()
    assert uniform_environment(loaded.scene.environment) is None  # the renderer: split sum
    lights = map_lights(loaded.scene.environment)  # the ray-caster's reference integration
    assert len(lights) == 256  # the default samples of a map
    # a uniform radiance of 2 (to RGBE's step) at intensity 0.5: sum c = 4 L / pi * ... = 4 L
    total = np.sum([x.color for x in lights], axis=0)
    assert np.allclose(total, 4.0 * 1.0, rtol=0.01)


@pytest.mark.parametrize(
    ("env", "key", "message"),
    [
        ('source = "image"\nfile = "missing.hdr"', "environment.file", "no such file"),
        ('source = "image"\nfile = "junk.hdr"', "environment.file", "not a Radiance"),
        ('source = "image"\nfile = "junk.exr"', "environment.file", "not a readable OpenEXR"),
        ('source = "image"\nfile = "zero.hdr"', "environment.file", "zero-size"),
        ('source = "image"\nfile = "nan.exr"', "environment.file", "3 NaN, infinite or neg"),
        ('source = "image"\nfile = "square.exr"', "environment.file", "not an equirect"),
        ('source = "image"\nfile = "grey.png"', "environment.file", "not an HDR image"),
        ('source = "image"', "environment.file", "needs it"),
        ('file = "x.hdr"', "environment.file", 'only with source = "image"'),
        (
            'source = "sky"\nsun_direction = [0.0, -1.0, 0.0]',
            "environment.sun_direction",
            "horizon",
        ),
        ('source = "studio"\nturbidity = 3.0', "environment.turbidity", "only with"),
        ("rotation = 10.0", "environment.rotation", "uniform"),
    ],
)
def test_bad_environment_input(tmp_path: Path, env: str, key: str, message: str) -> None:
    import OpenEXR

    (tmp_path / "junk.hdr").write_bytes(b"hello")
    (tmp_path / "junk.exr").write_bytes(b"hello")
    (tmp_path / "grey.png").write_bytes(b"\x89PNG")
    (tmp_path / "zero.hdr").write_bytes(b"#?RADIANCE\n\n-Y 0 +X 0\n")
    bad = np.ones((4, 8, 3), np.float32)
    bad[0, 0] = [np.nan, -1.0, np.inf]
    for name, px in (("nan.exr", bad), ("square.exr", np.ones((4, 4, 3), np.float32))):
        with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": px}) as f:
            f.write(str(tmp_path / name))
    with pytest.raises(InputError) as err:
        load_scene(scene_with(tmp_path, env))
    assert err.value.key == key and message in err.value.message
    assert err.value.file.endswith("s.toml")


def test_cell_integrals_turn_with_rotation() -> None:
    """A bright patch at +X in the map lands in the cell of -Z once turned 90 degrees."""
    env = np.zeros((64, 128, 3), np.float32)
    env[30:34, 94:98] = 1.0  # around +X (three quarters across, at the horizon)
    dirs = fibonacci_sphere(256)
    for rotation, world in ((0.0, [1.0, 0.0, 0.0]), (90.0, [0.0, 0.0, -1.0])):
        cells = cell_integrals(env, dirs, rotation)
        assert np.argmax(cells[:, 0]) == np.argmax(dirs @ world)


@pytest.mark.parametrize(
    "data",
    [
        {"radiance": [0.5, 0.5, 0.5]},
        {"source": "sky", "turbidity": 4.0, "rotation": 30.0},
        {"source": "studio", "intensity": 2.0, "background": True},
    ],
)
def test_a_dumped_environment_validates_again(data):
    """The renderer's edits, the comparisons and the walkthrough re-validate
    ``model_dump()``, which writes every key at its default: that must not read as a key
    given for another source (a uniform environment refused its own default rotation)."""
    from app.scene.model import Environment

    env = Environment.model_validate(data)
    assert Environment.model_validate(env.model_dump()) == env
    with pytest.raises(ValueError, match="rotation"):
        Environment.model_validate({"rotation": 10.0})


def test_a_dumped_default_sample_count_follows_a_new_source():
    """A sample count left to the source's default stays the default through
    ``model_dump()``: a dumped uniform environment (128 directions) turned into a sky gets
    the sky's 256 cell lights, not the uniform's 128; a count the file gave is kept."""
    from app.scene.model import MAP_SAMPLES, UNIFORM_SAMPLES, Environment

    env = Environment.model_validate({"radiance": [0.5, 0.5, 0.5]})
    assert env.samples == UNIFORM_SAMPLES != MAP_SAMPLES
    for dumped in (env.model_dump(), env.model_dump(exclude_none=True)):
        dumped.pop("radiance")
        assert Environment.model_validate({**dumped, "source": "sky"}).samples == MAP_SAMPLES
    given = Environment.model_validate({"radiance": [0.5, 0.5, 0.5], "samples": 64})
    assert Environment.model_validate({**given.model_dump(), "source": "sky",
                                       "radiance": [1.0, 1.0, 1.0]}).samples == 64  # fmt: skip
