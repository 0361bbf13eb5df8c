"""Procedural textures (app/textures/procedural.py, docs/textures.md) and ``pbs textures``.

The generators are deterministic and tile; the normal map is unit length within 8-bit
quantisation, faces out of the surface and follows the OpenGL convention (+X along +u,
+Y along +v = up the image); the rust mask covers the stated area with graded edges; and
``pbs textures --check`` accepts the checked-in files and rejects a tampered copy.

Measured on the checked-in files: seam / interior mean line difference 0.00-1.07 (limit 2;
cropped, non-tiling copies 3.4-64); decoded normals' |1 - |n|| <= 0.0061 and z >= 0.71;
474 bumps, slopes median 16.7 and at most 45.0 degrees; rust coverage 0.338 (seeds 1-3:
0.345-0.349).
"""

from __future__ import annotations

import io
import shutil
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from app.reference.tonemap import srgb_decode
from app.resources import scenes_dir
from app.textures import procedural
from app.textures.procedural import (
    TEXTURES,
    bump_height,
    bumpy_normal_map,
    decode_normals,
    encode_normals,
    fbm,
    height_gradient,
    normals_from_height,
    png_bytes,
    rust_color,
    rust_mask,
    value_noise,
)

BY_NAME = {texture.name: texture for texture in TEXTURES}
QUANTUM = 1.0 / 255.0  # one 8-bit step; decoding n = c * 2 - 1 doubles the rounding's half step


@pytest.fixture(scope="module")
def pixels() -> dict[str, np.ndarray]:
    """Every texture's 8-bit pixels, generated once."""
    return {texture.name: texture.pixels() for texture in TEXTURES}


# -- determinism ----------------------------------------------------------------------------

GENERATORS: dict[str, Callable[[int, int], np.ndarray]] = {
    "value_noise": lambda size, seed: value_noise(size, 8, seed),
    "fbm": lambda size, seed: fbm(size, seed),
    "rust_mask": rust_mask,
    "rust_color": rust_color,
    "bumpy_normal_map": bumpy_normal_map,
    "brushed_anisotropy": procedural.brushed_anisotropy,
    "brushed_roughness": procedural.brushed_roughness,
    "noise": procedural.noise,
    "brushed_direction": procedural.brushed_direction,
}


@pytest.mark.parametrize("name", GENERATORS)
def test_generator_is_a_function_of_its_seed(name: str) -> None:
    """The same seed gives bit-identical float64 arrays; another seed gives another one."""
    make = GENERATORS[name]
    first, again, other = make(128, 7), make(128, 7), make(128, 8)
    assert first.dtype == np.float64
    assert np.array_equal(first, again)
    assert np.mean(first != other) > 0.5


def test_png_bytes_are_deterministic_and_carry_no_metadata(pixels: dict[str, np.ndarray]) -> None:
    """Two encodings of each texture are byte-identical and hold only IHDR, IDAT and IEND
    chunks: no time stamp or text that would change from run to run."""
    for texture in TEXTURES:
        data = png_bytes(pixels[texture.name], texture.mode)
        assert data == png_bytes(texture.pixels(), texture.mode), texture.name
        chunks, at = [], 8
        while at < len(data):
            length = int.from_bytes(data[at : at + 4], "big")
            kind = data[at + 4 : at + 8]
            assert zlib.crc32(data[at + 4 : at + 8 + length]) == int.from_bytes(
                data[at + 8 + length : at + 12 + length], "big"
            )
            chunks.append(kind.decode("ascii"))
            at += 12 + length
        assert set(chunks) == {"IHDR", "IDAT", "IEND"}, (texture.name, chunks)
        with Image.open(io.BytesIO(data)) as image:
            assert image.mode == texture.mode
            assert np.array_equal(np.asarray(image), pixels[texture.name])


def test_noise_stays_in_unit_range() -> None:
    """value_noise and fbm return float64 in [0, 1] (convex blends of lattice values) and
    use most of it (value noise) or its middle (fbm averages octaves)."""
    v = value_noise(256, (3, 17), seed=1)
    f = fbm(256, seed=1)
    for a in (v, f):
        assert a.dtype == np.float64 and a.shape == (256, 256)
        assert a.min() >= 0.0 and a.max() <= 1.0
    assert v.max() - v.min() > 0.8
    assert f.max() - f.min() > 0.4
    with pytest.raises(ValueError, match="period"):
        value_noise(64, 65, seed=1)


# -- tiling ---------------------------------------------------------------------------------

# A tiling texture's wrap-around pair (last row or column against the first) differs by
# about as much as neighbouring interior pairs: measured 0.00-1.07 times their mean (below
# 1 where every noise lattice has a line at the seam and the quintic fade is flat; 0.00
# along the brushed streaks), while a copy cropped to 2/3, which does not tile, measures
# 3.4-64 on the checked-in files.
SEAM_FACTOR = 2.0


def seam_ratio(image: np.ndarray, axis: int) -> float:
    """Mean |last - first| line along ``axis`` over the mean |difference| of neighbouring
    interior lines (all channels)."""
    a = np.moveaxis(np.asarray(image, np.float64), axis, 0)
    interior = np.abs(np.diff(a, axis=0)).mean()
    return float(np.abs(a[-1] - a[0]).mean() / interior)


@pytest.mark.parametrize("name", list(BY_NAME))
def test_texture_tiles_seamlessly(pixels: dict[str, np.ndarray], name: str) -> None:
    """The seam across u (columns) and across v (rows) is no rougher than SEAM_FACTOR times
    the interior; the same statistic flags a non-tiling crop of the texture (the control)."""
    image = pixels[name]
    n = image.shape[0]
    for axis in (0, 1):
        assert seam_ratio(image, axis) < SEAM_FACTOR, (name, axis)
    assert seam_ratio(image[:, : n - n // 3], 1) > SEAM_FACTOR, (name, "control u")
    assert seam_ratio(image[: n - n // 3], 0) > SEAM_FACTOR, (name, "control v")


# -- the normal map -------------------------------------------------------------------------


def test_normal_map_is_unit_and_faces_out(pixels: dict[str, np.ndarray]) -> None:
    """Decoded texels are unit vectors up to 8-bit rounding (each component within one step
    of 2/255 / 2, so |1 - |n|| <= sqrt(3)/255) and point out of the surface (z > 0)."""
    rgb = pixels["bumpy_normal.png"]
    assert rgb.shape == (256, 256, 3)
    n = decode_normals(rgb)
    assert np.abs(np.linalg.norm(n, axis=-1) - 1.0).max() <= np.sqrt(3.0) * QUANTUM
    assert n[..., 2].min() > 0.0


def test_normal_map_is_dense_bumps_up_to_45_degrees(pixels: dict[str, np.ndarray]) -> None:
    """Several hundred bumps per tile (local maxima of the height field) with slopes up to
    45 degrees (within a degree after 8-bit rounding) and a median between 10 and 25."""
    h = bump_height()
    peak = np.ones_like(h, dtype=bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy or dx:
                peak &= h > np.roll(h, (dy, dx), axis=(0, 1))
    assert 300 <= int(peak.sum()) <= 576
    n = decode_normals(pixels["bumpy_normal.png"])
    slope = np.degrees(np.arccos(n[..., 2] / np.linalg.norm(n, axis=-1)))
    assert abs(slope.max() - 45.0) < 1.0
    assert 10.0 < np.median(slope) < 25.0


def _uv(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Texel centres' (u, v) in the renderer's convention: u along columns, v up the image
    (row 0 is the top, v near 1)."""
    centres = (np.arange(size) + 0.5) / size
    u = np.broadcast_to(centres[None, :], (size, size))
    v = np.broadcast_to(1.0 - centres[:, None], (size, size))
    return u, v


@pytest.mark.parametrize("axis", ["u", "v"])
def test_height_rising_towards_plus_u_or_v_tilts_the_normal_back(axis: str) -> None:
    """OpenGL convention: where h(u, v) = A sin(2 pi u) rises towards +u, the stored normal
    has x < 0 (it leans towards -u, away from the rise), and likewise y < 0 where h rises
    towards +v (up the image); the decoded PNG matches -h'/sqrt(1 + h'^2) within one 8-bit
    step (the central differences add < 1e-4 of a slope of 0.13)."""
    size, amplitude = 256, 0.02
    u, v = _uv(size)
    t = u if axis == "u" else v
    height = amplitude * np.sin(2.0 * np.pi * t)
    n = decode_normals(encode_normals(normals_from_height(height)))
    slope = 2.0 * np.pi * amplitude * np.cos(2.0 * np.pi * t)
    along, across = (n[..., 0], n[..., 1]) if axis == "u" else (n[..., 1], n[..., 0])
    rising = slope > 0.05
    assert np.all(along[rising] < 0.0) and np.all(along[slope < -0.05] > 0.0)
    assert np.abs(along - (-slope / np.sqrt(1.0 + slope**2))).max() <= 1.01 * QUANTUM
    assert np.abs(across).max() <= 1.01 * QUANTUM


def test_bumpy_map_follows_its_height_field(pixels: dict[str, np.ndarray]) -> None:
    """The PNG's x and y follow -dh/du and -dh/dv of the bumps (correlation > 0.99): rows
    were not stored upside down, nor the channels swapped."""
    du, dv = height_gradient(bump_height())
    n = decode_normals(pixels["bumpy_normal.png"])
    assert np.corrcoef(n[..., 0].ravel(), -du.ravel())[0, 1] > 0.99
    assert np.corrcoef(n[..., 1].ravel(), -dv.ravel())[0, 1] > 0.99


# -- rust and brushed metal -----------------------------------------------------------------


@pytest.mark.parametrize("seed", [41, 1, 2, 3])
def test_rust_covers_30_to_40_percent_with_graded_edges(seed: int) -> None:
    """The mask's mean and its area above 0.5 lie in [0.30, 0.40] (measured 0.338-0.351),
    and it is not binary: moving a scene's threshold from 0.25 to 0.75 shrinks the rusted
    area by at least 0.05 (measured ~0.12)."""
    m = rust_mask(512, seed)
    assert m.min() >= 0.0 and m.max() <= 1.0
    assert 0.30 <= m.mean() <= 0.40
    assert 0.30 <= np.mean(m > 0.5) <= 0.40
    assert np.mean(m > 0.25) - np.mean(m > 0.75) >= 0.05


def test_rust_colour_is_dark_orange_stored_as_srgb(pixels: dict[str, np.ndarray]) -> None:
    """Linear albedo: red 0.13-0.47 with green below red and blue below green everywhere;
    the PNG decodes (sRGB) back to it within half an 8-bit step of the sRGB curve."""
    c = rust_color()
    assert c[..., 0].min() >= 0.13 and c[..., 0].max() <= 0.47
    assert np.all(c[..., 1] < c[..., 0]) and np.all(c[..., 2] < c[..., 1])
    decoded = srgb_decode(pixels["rust_color.png"] / 255.0)
    # The sRGB decode's slope is 2.4/1.055 ((e + 0.055)/1.055)^1.4 <= 1.5 up to the brightest
    # texel (e = 180/255), so rounding (half a step) moves the linear value by < 0.75/255;
    # storing linear values as they are would err by up to 0.2.
    assert np.abs(decoded - c).max() < 0.75 * QUANTUM


@pytest.mark.parametrize(
    ("name", "lo", "hi"),
    [("brushed_anisotropy.png", 0.5, 0.9), ("brushed_roughness.png", 0.25, 0.45)],
)
def test_brushed_maps_streak_along_u(
    pixels: dict[str, np.ndarray], name: str, lo: float, hi: float
) -> None:
    """Values span [lo, hi] (to an 8-bit step), and neighbouring rows (across v) differ at
    least 10 times more than neighbouring columns (along u): streaks along u (measured 22)."""
    a = pixels[name] / 255.0
    assert abs(a.min() - lo) <= QUANTUM / 2 + 1e-12 and abs(a.max() - hi) <= QUANTUM / 2 + 1e-12
    across_v = np.abs(np.diff(a, axis=0)).mean()
    along_u = np.abs(np.diff(a, axis=1)).mean()
    assert across_v > 10.0 * along_u


def test_brushed_direction_is_unit_within_75_degrees(pixels: dict[str, np.ndarray]) -> None:
    """The direction map decodes (2 rg - 1) to unit vectors (to 8-bit rounding) within 75
    degrees of +u, so no two neighbours point opposite ways, and B (the strength) is 1."""
    rgb = pixels["brushed_direction.png"] / 255.0
    d = 2.0 * rgb[..., :2] - 1.0
    assert np.abs(np.linalg.norm(d, axis=-1) - 1.0).max() <= 2.0 * QUANTUM
    angle = np.degrees(np.arctan2(d[..., 1], d[..., 0]))
    assert np.abs(angle).max() <= 75.0 + 0.5 and np.abs(angle).max() > 70.0
    assert np.all(rgb[..., 2] == 1.0)


# -- pbs textures ---------------------------------------------------------------------------


def test_check_accepts_the_checked_in_textures(capsys: pytest.CaptureFixture[str]) -> None:
    """scenes/textures/ holds exactly what the generators make (CI proof of provenance)."""
    assert main(["textures", "--check"]) == 0
    out = capsys.readouterr().out
    for texture in TEXTURES:
        assert (scenes_dir() / "textures" / texture.name).is_file()
        assert f"{texture.name}: matches" in out


def test_write_then_check_then_tamper(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The command writes one line per file and byte-identical PNGs each run; --check passes
    on them, then fails (exit 1) naming just the file with one changed texel, and a
    missing file."""
    assert main(["textures", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == len(TEXTURES)
    for line, texture in zip(lines, TEXTURES, strict=True):
        assert line.startswith(str(tmp_path / texture.name)) and texture.what in line
    again = tmp_path / "again"
    assert main(["textures", "--out", str(again), "-q"]) == 0
    for texture in TEXTURES:
        assert (tmp_path / texture.name).read_bytes() == (again / texture.name).read_bytes()
    assert main(["textures", "--check", "--out", str(tmp_path)]) == 0
    capsys.readouterr()

    target = tmp_path / "bumpy_normal.png"
    with Image.open(target) as image:
        tampered = np.asarray(image).copy()
    tampered[100, 100, 1] ^= 1
    Image.fromarray(tampered, "RGB").save(target)
    assert main(["textures", "--check", "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert "bumpy_normal.png: differs: 1 of 196608 values differ" in captured.out
    assert "bumpy_normal.png" in captured.err and "rust_mask.png" not in captured.err

    shutil.copy(again / "bumpy_normal.png", target)
    (tmp_path / "noise.png").unlink()
    assert main(["textures", "--check", "--out", str(tmp_path), "-q"]) == 1
    captured = capsys.readouterr()
    assert captured.out.strip() == f"{tmp_path / 'noise.png'}: differs: missing"


def test_out_that_is_a_file_is_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--out naming a file exits 2 with one line naming it, and writes nothing."""
    path = tmp_path / "file.txt"
    path.write_text("x", encoding="utf-8")
    assert main(["textures", "--out", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"pbs: error: {path}: --out: not a folder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]
