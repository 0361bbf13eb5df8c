"""Procedural material textures for section 13's blending and filtering scenes: tileable
noise, a rust mask and rust colour, a bumpy high-frequency normal map and brushed-metal
anisotropy and roughness (docs/textures.md). ``pbs textures`` writes them to
``scenes/textures/`` and ``pbs textures --check`` proves the checked-in files come from here.

Every generator is a pure function of ``(size, seed)``, vectorised over pixels, and tiles:
all noise lives on periodic lattices with a whole number of cells across the image, so
the last column continues into the first and the last row into the first (scenes repeat
them with a UV scale). Random numbers are the raw output of NumPy's PCG64 bit generator
seeded through ``SeedSequence``, turned into floats here: the layer of ``numpy.random``
least likely to change between versions (``Generator`` methods may change their
algorithms); should it change, ``pbs textures --check`` on the checked-in files says so.
Each texture has its own seed; within one, every random draw has its own stream number.

UV and tangent-space convention (the renderer's, OpenGL's): u grows along image columns
(left to right) and v grows up the image, so image row 0 (the top) is v = 1; glTF files'
texture coordinates are flipped to this by trimesh on load, and the G-buffer pass uploads
images bottom row first. A tangent-space normal has +X along +u (image right), +Y along
+v (image up: the glTF / OpenGL "green up" convention) and +Z out of the surface.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from app.output import atomic_write
from app.reference.tonemap import srgb_encode

NORMAL_MAP_SIZE = 256
TEXTURE_SIZE = 512
PNG_COMPRESS_LEVEL = 9

# Rust covers this fraction of the sheet: the fBm's (1 - RUST_PATCH_AREA) quantile is the
# middle of the soft ramp, and the speckles add ~0.02 on top (measured 0.338-0.349 in all).
RUST_PATCH_AREA = 0.32
# Half-width of the patches' soft ramp in standard deviations of the fBm: wide enough that
# a scene's mask threshold and softness still move the edges (24-31% of the pixels lie
# between 0.02 and 0.98), narrow enough that the patches read as patches.
RUST_RAMP_SIGMAS = 0.45
# The bumps' steepest slope: the height field is scaled so that its largest slope angle
# (from the central differences the normals use) is exactly this.
MAX_BUMP_SLOPE_DEG = 45.0
RUST_SPECKLE_CELLS = 64  # lattice of the candidate speckles (8 pixels per cell at 512)
BUMP_CELLS = 24  # bumps per side of the tile: 576 bumps, one per jittered lattice cell
# Metal flakes of car paint (RTR4 §9.12's layers with different normals): one flat flake
# per jittered lattice cell (Voronoi cells, ~5 pixels across at 256), each tilted by up to
# this many degrees, so that under a light only the flakes facing it glint.
FLAKE_CELLS = 48
MAX_FLAKE_TILT_DEG = 20.0
# "Orange peel", the clear coat's gentle waviness: its steepest slope in degrees.
ORANGE_PEEL_SLOPE_DEG = 12.0
# Grooves along u (scenes/sec13_grooves.toml): their steepest slope in degrees, and the map's
# side (small: 16 lattice cells across the grooves, 8 texels each).
MAX_GROOVE_SLOPE_DEG = 30.0
GROOVE_MAP_SIZE = 128


# -- random numbers and noise ------------------------------------------------------------------


def uniform(seed: int, stream: int, shape: tuple[int, ...]) -> np.ndarray:
    """Uniform float64 in [0, 1) of ``shape``: stream ``stream`` of ``seed``, the top 53
    bits of each raw PCG64 output (no ``Generator`` method in between)."""
    bits = np.random.PCG64(np.random.SeedSequence([seed, stream]))
    raw = bits.random_raw(int(np.prod(shape)))
    return ((raw >> np.uint64(11)).astype(np.float64) * 2.0**-53).reshape(shape)


def _fade(t: np.ndarray) -> np.ndarray:
    """Perlin 2002's quintic 6t^5 - 15t^4 + 10t^3: C2 across lattice cells, in [0, 1]."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _lattice_axis(size: int, period: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel i at lattice coordinate i * period / size: its cell, the next cell (wrapping
    at ``period``) and the faded fraction between them."""
    x = np.arange(size, dtype=np.float64) * (period / size)
    cell = np.floor(x).astype(np.int64)
    return cell % period, (cell + 1) % period, _fade(x - cell)


def value_noise(size: int, period: int | tuple[int, int], seed: int, stream: int = 0) -> np.ndarray:
    """Tileable value noise: random values in [0, 1) on a lattice of ``period`` cells across
    the image (an int, or (cells along u, cells along v) for stretched noise), blended with
    the quintic fade. A (size, size) float64 array in [0, 1]; the lattice wraps, so the
    image tiles. Unequal periods stretch the noise: few cells along u make streaks along u.
    """
    pu, pv = (period, period) if isinstance(period, int) else period
    if not (1 <= pu <= size and 1 <= pv <= size):
        raise ValueError(f"lattice period {(pu, pv)} outside 1..{size}")
    lattice = uniform(seed, stream, (pv, pu))  # [row (v), column (u)]
    r0, r1, fr = _lattice_axis(size, pv)
    c0, c1, fc = _lattice_axis(size, pu)
    top = lattice[np.ix_(r0, c0)] * (1.0 - fc) + lattice[np.ix_(r0, c1)] * fc
    bottom = lattice[np.ix_(r1, c0)] * (1.0 - fc) + lattice[np.ix_(r1, c1)] * fc
    return top * (1.0 - fr[:, None]) + bottom * fr[:, None]


def fbm(
    size: int,
    seed: int,
    period: int | tuple[int, int] = 4,
    octaves: int = 6,
    gain: float = 0.5,
    stream: int = 0,
) -> np.ndarray:
    """Fractional Brownian motion (Musgrave's fBm): ``octaves`` of ``value_noise``, each
    with twice the previous lattice frequency (capped at one cell per pixel) and ``gain``
    times its amplitude, divided by the sum of the amplitudes. Float64 in [0, 1], tileable;
    most values sit near 0.5 (the octaves average out), so callers stretch or threshold.
    Octave k draws its lattice from random stream ``stream + k`` of ``seed``.
    """
    pu, pv = (period, period) if isinstance(period, int) else period
    total = np.zeros((size, size))
    weight = 0.0
    amplitude = 1.0
    for octave in range(octaves):
        scale = 2**octave
        cells = (min(pu * scale, size), min(pv * scale, size))
        total += amplitude * value_noise(size, cells, seed, stream=stream + octave)
        weight += amplitude
        amplitude *= gain
    return total / weight


def stretch(values: np.ndarray) -> np.ndarray:
    """``values`` mapped linearly onto [0, 1] (minimum to 0, maximum to 1)."""
    lo, hi = float(values.min()), float(values.max())
    return (values - lo) / (hi - lo) if hi > lo else np.zeros_like(values)


def smoothstep(edge0: float, edge1: float, x: np.ndarray) -> np.ndarray:
    """GLSL's smoothstep: 0 below ``edge0``, 1 above ``edge1``, Hermite in between."""
    t = np.clip((x - edge0) / (edge1 - edge0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def jittered_spots(
    size: int,
    cells: int,
    seed: int,
    radius: np.ndarray,
    amplitude: np.ndarray,
    profile: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray:
    """Sum of round spots, one per cell of a tileable ``cells`` x ``cells`` lattice, each
    at a random point of its cell (0.15-0.85 of the way across, so no two centres are
    closer than 0.3 cells) with ``radius`` (in cells, at most 0.95) and ``amplitude`` per
    cell: spot value ``amplitude * profile(r² / radius²)`` for ``profile`` zero from 1 on.

    A spot reaches at most 0.85 + 0.95 < 2 cells from its cell's start, so only the 3x3
    cells around a pixel's cell touch it and summing those is exact; the loop runs over
    the nine offsets, each step vectorised over all pixels.
    """
    if float(np.max(radius)) > 0.95:
        raise ValueError(f"spot radius {float(np.max(radius))} cells exceeds 0.95")
    jitter = 0.15 + 0.7 * uniform(seed, 1000, (cells, cells, 2))  # [row, column, (x, y)]
    # Pixel centres in lattice units: x along u (columns), y down the image (rows).
    x = (np.arange(size) + 0.5) * (cells / size)
    cx = np.floor(x).astype(np.int64)
    total = np.zeros((size, size))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            cell = np.ix_((cx + dy) % cells, (cx + dx) % cells)  # the neighbour, wrapped
            px = (cx + dx)[None, :] + jitter[..., 0][cell]
            py = (cx + dy)[:, None] + jitter[..., 1][cell]
            s = ((x[None, :] - px) ** 2 + (x[:, None] - py) ** 2) / radius[cell] ** 2
            total += amplitude[cell] * profile(s)
    return total


def _dot_profile(s: np.ndarray) -> np.ndarray:
    """A solid dot: 1 inside, falling linearly to 0 over its outer third (in r²)."""
    return np.clip(3.0 * (1.0 - s), 0.0, 1.0)


def _bump_profile(s: np.ndarray) -> np.ndarray:
    """A round bump (1 - r²/R²)³: smooth (C2) where it meets the ground at r = R."""
    return np.clip(1.0 - s, 0.0, None) ** 3


# -- the textures ------------------------------------------------------------------------------


def rust_mask(size: int = TEXTURE_SIZE, seed: int = 41) -> np.ndarray:
    """Coverage in [0, 1] of rust patches on a metal sheet (1 = rust), linear data.

    Blotches: fBm (period 4, 6 octaves, gain 0.6 for ragged edges) through a soft ramp
    ``RUST_RAMP_SIGMAS`` standard deviations either side of its ``1 - RUST_PATCH_AREA``
    quantile, so the patches cover that fraction whatever the seed and keep graded edges
    for a scene's mask threshold and softness to act on. Speckles: round dots of 1.6-3.6
    pixels' radius in 30% of the cells of a 64 x 64 jittered lattice, kept only where a
    coarse value noise (period 8) is high, so they cluster in parts of the bare metal.
    """
    f = fbm(size, seed, period=4, octaves=6, gain=0.6)
    middle = float(np.quantile(f, 1.0 - RUST_PATCH_AREA))
    half = RUST_RAMP_SIGMAS * float(f.std())
    patches = smoothstep(middle - half, middle + half, f)
    g = RUST_SPECKLE_CELLS
    present = uniform(seed, 200, (g, g)) < 0.3
    radius = 0.2 + 0.25 * uniform(seed, 201, (g, g))
    dots = jittered_spots(size, g, seed, radius, present.astype(np.float64), _dot_profile)
    cluster = value_noise(size, 8, seed, stream=202)
    speckles = np.minimum(dots, 1.0) * smoothstep(0.35, 0.7, cluster)
    return np.maximum(patches, speckles)


def rust_color(size: int = TEXTURE_SIZE, seed: int = 42) -> np.ndarray:
    """Linear base colour (size, size, 3) of rust: dark brown to orange.

    A medium fBm (period 8) blends dark brown (0.15, 0.05, 0.02) into orange
    (0.42, 0.15, 0.04), linear albedo: dark and red-dominated like iron oxide; a fine fBm
    (period 64) scales it by 0.9-1.1 so the colour is granular, not smooth. Red spans
    about 0.14-0.46. Encoded to sRGB when written (``TEXTURES``).
    """
    brown = np.array([0.15, 0.05, 0.02])
    orange = np.array([0.42, 0.15, 0.04])
    t = smoothstep(0.15, 0.85, stretch(fbm(size, seed, period=8, octaves=5)))[..., None]
    grain = 1.0 + 0.2 * (stretch(fbm(size, seed, period=64, octaves=3, stream=10)) - 0.5)
    return np.clip((brown * (1.0 - t) + orange * t) * grain[..., None], 0.0, 1.0)


def bump_height(size: int = NORMAL_MAP_SIZE, seed: int = 43) -> np.ndarray:
    """A tileable field of dense small round bumps, heights in units of the tile's width.

    ``BUMP_CELLS``² jittered bumps with random radii of 0.5-0.95 cells (so neighbours
    overlap) and heights of 0.5-1, each the compact kernel (1 - r²/R²)³, smooth (C2) at its
    rim. The field is scaled so that its steepest slope is ``MAX_BUMP_SLOPE_DEG``.
    """
    g = BUMP_CELLS
    radius = 0.5 + 0.45 * uniform(seed, 1, (g, g))
    amplitude = 0.5 + 0.5 * uniform(seed, 2, (g, g))
    height = jittered_spots(size, g, seed, radius, amplitude, _bump_profile)
    du, dv = height_gradient(height)
    steepest = float(np.sqrt(du * du + dv * dv).max())
    return height * (np.tan(np.radians(MAX_BUMP_SLOPE_DEG)) / steepest)


def height_gradient(height: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dh/du, dh/dv) of a tileable height field by central differences with wrap-around,
    for heights in units of the tile's width. Column c + 1 is further along +u; row r - 1
    (up the image) is further along +v."""
    n_rows, n_cols = height.shape
    du = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * (n_cols / 2.0)
    dv = (np.roll(height, 1, axis=0) - np.roll(height, -1, axis=0)) * (n_rows / 2.0)
    return du, dv


def normals_from_height(height: np.ndarray) -> np.ndarray:
    """Unit tangent-space normals (H, W, 3) of the surface z = height(u, v):
    normalize(-dh/du, -dh/dv, 1), +X along +u, +Y along +v (image up), +Z out."""
    du, dv = height_gradient(height)
    n = np.stack([-du, -dv, np.ones_like(du)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def bumpy_normal_map(size: int = NORMAL_MAP_SIZE, seed: int = 43) -> np.ndarray:
    """Unit tangent-space normals (size, size, 3) of ``bump_height``: z >= cos 45 degrees."""
    return normals_from_height(bump_height(size, seed))


def flake_normal_map(size: int = NORMAL_MAP_SIZE, seed: int = 47) -> np.ndarray:
    """Unit tangent-space normals (size, size, 3) of metal flakes: a tileable Voronoi
    diagram of ``FLAKE_CELLS``² jittered sites, each cell one flat flake with its own tilt
    (polar angle up to ``MAX_FLAKE_TILT_DEG``, uniform over the disc of tilts; azimuth
    uniform). The nearest site of a pixel lies in its cell or the 8 around it (the sites
    keep 0.15-0.85 of their cells, as ``jittered_spots``'), so those nine decide."""
    g = FLAKE_CELLS
    jitter = 0.15 + 0.7 * uniform(seed, 1000, (g, g, 2))  # [row, column, (x, y)]
    theta = np.radians(MAX_FLAKE_TILT_DEG) * np.sqrt(uniform(seed, 1, (g, g)))
    phi = 2.0 * np.pi * uniform(seed, 2, (g, g))
    flakes = np.stack(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1
    )
    x = (np.arange(size) + 0.5) * (g / size)
    cx = np.floor(x).astype(np.int64)
    nearest = np.full((size, size), np.inf)
    normals = np.zeros((size, size, 3))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            cell = np.ix_((cx + dy) % g, (cx + dx) % g)
            px = (cx + dx)[None, :] + jitter[..., 0][cell]
            py = (cx + dy)[:, None] + jitter[..., 1][cell]
            d = (x[None, :] - px) ** 2 + (x[:, None] - py) ** 2
            closer = d < nearest
            nearest = np.where(closer, d, nearest)
            normals = np.where(closer[..., None], flakes[cell], normals)
    return normals


def orange_peel_normal_map(size: int = NORMAL_MAP_SIZE, seed: int = 48) -> np.ndarray:
    """Unit tangent-space normals (size, size, 3) of a clear coat's "orange peel": a smooth
    fBm height field (period 6, 3 octaves, gain 0.4: broad, soft undulations) scaled so
    that its steepest slope is ``ORANGE_PEEL_SLOPE_DEG``."""
    height = fbm(size, seed, period=6, octaves=3, gain=0.4) / size
    du, dv = height_gradient(height)
    steepest = float(np.sqrt(du * du + dv * dv).max())
    return normals_from_height(height * (np.tan(np.radians(ORANGE_PEEL_SLOPE_DEG)) / steepest))


def groove_normal_map(size: int = GROOVE_MAP_SIZE, seed: int = 49) -> np.ndarray:
    """Unit tangent-space normals (size, size, 3) of fine grooves running along u (brushed
    or lathe-turned metal): a height field of noise stretched 8-fold along u (lattice
    periods (2, 16) and one finer octave), scaled so that its steepest slope is
    ``MAX_GROOVE_SLOPE_DEG``. The normals tilt almost only across the grooves (along v):
    their spread is anisotropic, what ``render.normal_filter = "lean"`` keeps
    (docs/filtering.md)."""
    height = fbm(size, seed, period=(2, 16), octaves=2, gain=0.5) / size
    du, dv = height_gradient(height)
    steepest = float(np.sqrt(du * du + dv * dv).max())
    return normals_from_height(height * (np.tan(np.radians(MAX_GROOVE_SLOPE_DEG)) / steepest))


def brushed_anisotropy(size: int = TEXTURE_SIZE, seed: int = 44) -> np.ndarray:
    """Anisotropy strength in [0.5, 0.9] of brushed metal, streaked along u.

    Noise stretched 32-fold along u (lattice periods (2, 64) up to (32, 1024 capped at the
    size)): each octave varies little along a row and a lot across rows, like brushing
    scratches; stretched onto [0, 1] and mapped to 0.5 + 0.4 x.
    """
    streaks = fbm(size, seed, period=(2, 64), octaves=5, gain=0.6)
    return 0.5 + 0.4 * stretch(streaks)


def brushed_roughness(size: int = TEXTURE_SIZE, seed: int = 45) -> np.ndarray:
    """Perceptual roughness in [0.25, 0.45] of brushed metal, streaked along u like
    ``brushed_anisotropy`` (an independent seed) plus a faint broad fBm so the sheet is
    not uniformly worn: 0.25 + 0.2 x (stretched)."""
    streaks = fbm(size, seed, period=(2, 64), octaves=5, gain=0.6)
    wear = fbm(size, seed, period=2, octaves=3, stream=10)
    return 0.25 + 0.2 * stretch(0.75 * streaks + 0.25 * wear)


def brushed_direction(size: int = NORMAL_MAP_SIZE, seed: int = 47) -> np.ndarray:
    """(H, W, 2) unit directions of anisotropy in the tangent frame (+x along +u, +y along
    +v), float64: brushing that swirls. The angle from +u is a broad fBm (period 2, 2
    octaves) stretched onto [-75, 75] degrees, so it never wraps and neighbouring texels
    never point opposite ways (their mips average, as glTF's sampler does)."""
    angle = np.radians(75.0) * (2.0 * stretch(fbm(size, seed, period=2, octaves=2)) - 1.0)
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def noise(size: int = TEXTURE_SIZE, seed: int = 46) -> np.ndarray:
    """Generic greyscale fBm (period 4, 6 octaves) stretched onto [0, 1]."""
    return stretch(fbm(size, seed, period=4, octaves=6))


# -- encoding and the list of files -------------------------------------------------------------


def quantize(values: np.ndarray) -> np.ndarray:
    """[0, 1] float -> uint8 by rounding to the nearest of 256 levels."""
    return np.rint(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def encode_normals(n: np.ndarray) -> np.ndarray:
    """Unit normals -> RGB8 n * 0.5 + 0.5 (linear, not sRGB)."""
    return quantize(np.asarray(n, np.float64) * 0.5 + 0.5)


def encode_directions(d: np.ndarray) -> np.ndarray:
    """Unit 2D directions -> RGB8 as glTF KHR_materials_anisotropy's anisotropyTexture
    holds them: RG = d * 0.5 + 0.5 (linear), B = 255 (the strength, 1)."""
    rg = quantize(np.asarray(d, np.float64) * 0.5 + 0.5)
    return np.dstack([rg, np.full(rg.shape[:2], 255, np.uint8)])


def decode_normals(rgb: np.ndarray) -> np.ndarray:
    """RGB8 -> n = rgb / 255 * 2 - 1 (not renormalised: within sqrt(3)/255 of unit)."""
    return np.asarray(rgb, np.float64) * (2.0 / 255.0) - 1.0


@dataclass(frozen=True)
class ProceduralTexture:
    """One file of ``scenes/textures/``: its name, PNG mode, what it holds, and how."""

    name: str
    mode: str  # "L", "RGB" or "RGBA"
    what: str
    pixels: Callable[[], np.ndarray]  # uint8, (H, W) for "L", (H, W, 3|4) for "RGB(A)"


TEXTURES: tuple[ProceduralTexture, ...] = (
    ProceduralTexture(
        "rust_mask.png", "L", "rust coverage mask, linear", lambda: quantize(rust_mask())
    ),
    ProceduralTexture(
        "rust_color.png",
        "RGB",
        "rust base colour, sRGB",
        lambda: quantize(srgb_encode(rust_color())),
    ),
    ProceduralTexture(
        "bumpy_normal.png",
        "RGB",
        "bumpy tangent-space normal map, n*0.5+0.5 linear, +Y up (OpenGL)",
        lambda: encode_normals(bumpy_normal_map()),
    ),
    ProceduralTexture(
        "brushed_anisotropy.png",
        "L",
        "brushed-metal anisotropy strength 0.5-0.9, streaks along u, linear",
        lambda: quantize(brushed_anisotropy()),
    ),
    ProceduralTexture(
        "brushed_roughness.png",
        "L",
        "brushed-metal perceptual roughness 0.25-0.45, streaks along u, linear",
        lambda: quantize(brushed_roughness()),
    ),
    ProceduralTexture("noise.png", "L", "generic fBm noise, linear", lambda: quantize(noise())),
    ProceduralTexture(
        "brushed_direction.png",
        "RGB",
        "swirling direction of anisotropy within 75 deg of +u, RG = d*0.5+0.5, B = 1 (glTF "
        "anisotropyTexture layout)",
        lambda: encode_directions(brushed_direction()),
    ),
    ProceduralTexture(
        "flake_normal.png",
        "RGB",
        "metal-flake tangent-space normal map (tilts up to 20 deg), n*0.5+0.5 linear",
        lambda: encode_normals(flake_normal_map()),
    ),
    ProceduralTexture(
        "orange_peel_normal.png",
        "RGB",
        "clear-coat orange-peel tangent-space normal map (slopes up to 12 deg), n*0.5+0.5",
        lambda: encode_normals(orange_peel_normal_map()),
    ),
    ProceduralTexture(
        "groove_normal.png",
        "RGB",
        "grooves along u, tangent-space normals (slopes up to 30 deg across u), n*0.5+0.5",
        lambda: encode_normals(groove_normal_map()),
    ),
    ProceduralTexture(
        "rusted_through.png",
        "RGBA",
        "rust base colour (sRGB) with coverage A = 1 - rust mask (linear): a sheet eaten "
        "through where the rust is (glTF alphaMode MASK)",
        lambda: rusted_through(),
    ),
)


def rusted_through() -> np.ndarray:
    """(H, W, 4) uint8: rust_color.png's RGB and the coverage 1 - rust_mask as alpha, so
    that a cutoff of 0.5 opens holes where the rust patches are (glTF 2.0 alphaMode MASK
    keeps a fragment where alpha >= alphaCutoff)."""
    rgb = quantize(srgb_encode(rust_color()))
    alpha = quantize(1.0 - rust_mask())
    return np.dstack([rgb, alpha])


def png_bytes(pixels: np.ndarray, mode: str) -> bytes:
    """The PNG of ``pixels``: compression level 9 and no metadata chunks (no time, no text),
    so the same pixels always give the same bytes with the same zlib."""
    buffer = io.BytesIO()
    Image.fromarray(pixels, mode).save(buffer, format="PNG", compress_level=PNG_COMPRESS_LEVEL)
    return buffer.getvalue()


def write_texture(path: Path, data: bytes) -> None:
    """Write a PNG's bytes through a temporary sibling renamed into place (no partial file)."""
    atomic_write(path, lambda tmp: tmp.write_bytes(data))


def difference(path: Path, texture: ProceduralTexture, pixels: np.ndarray) -> str | None:
    """Why the PNG at ``path`` does not hold ``texture``'s ``pixels``, or None if it does.

    The decoded pixels, mode and size are compared, not the file's bytes: the same pixels
    compress to other bytes under another zlib (Pillow's wheels have shipped zlib-ng), and
    the check must hold on any machine that runs the same generators.
    """
    if not path.is_file():
        return "missing"
    try:
        with Image.open(path) as image:
            image.load()
            kind, mode, stored = image.format, image.mode, np.asarray(image)
    except OSError as exc:  # PIL.UnidentifiedImageError and truncated files are OSErrors
        return f"unreadable ({exc})"
    if kind != "PNG" or mode != texture.mode:
        return f"{kind} {mode}, expected PNG {texture.mode}"
    if stored.shape != pixels.shape:
        found, wanted = stored.shape[1::-1], pixels.shape[1::-1]
        return f"{found[0]}x{found[1]}, expected {wanted[0]}x{wanted[1]}"
    changed = int(np.count_nonzero(stored != pixels))
    return f"{changed} of {stored.size} values differ" if changed else None
