"""Mip chains for normal and roughness maps (RTR4 §9.13): level 0 is the source, sizes
follow GL, a flat map keeps its roughness, bumps below a texel move into roughness by the
amount each method predicts, and the variance method is the exact box filter of the slope
moments (level 2 from level 1 = level 2 from the source).

Outputs are float32: r' carries one float32 rounding (relative 2^-24), so alpha'^2 = r'^4
carries ~4 of them; tolerances on alpha'^2 below are 1e-6 relative (~17 ulps).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.reference.filtering import alpha2_from_slope_variance, alpha2_toksvig
from app.textures.mips import (
    MIN_NORMAL_Z,
    NORMAL_FILTERS,
    box_mips,
    build_chain,
    decode_normal_map,
)

RNG_SEED = 20241130
F32_REL = 1e-6  # alpha'^2 = r'^4 from a float32 r': 4 roundings of 2^-24, with margin


def alpha2(r: np.ndarray) -> np.ndarray:
    """alpha^2 = r^4 of a float32 roughness level, in float64."""
    return np.asarray(r, np.float64) ** 4


def bumpy_normals(shape: tuple[int, int], slope_std: float, seed: int) -> np.ndarray:
    """Unit normals of random slopes (s.x, s.y) ~ N(0, slope_std^2): n = (-s.x, -s.y, 1)/|.|."""
    s = np.random.default_rng(seed).normal(0.0, slope_std, (*shape, 2))
    n = np.concatenate([-s, np.ones((*shape, 1))], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def checkerboard(shape: tuple[int, int], theta: float) -> np.ndarray:
    """Normals tilted by +theta and -theta about the x axis, alternating per texel:
    n = (0, -+sin theta, cos theta), slopes (0, +-tan theta)."""
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    sign = np.where((xx + yy) % 2 == 0, 1.0, -1.0)
    n = np.zeros((*shape, 3))
    n[..., 1] = -sign * math.sin(theta)
    n[..., 2] = math.cos(theta)
    return n


def slopes(n: np.ndarray) -> np.ndarray:
    return -n[..., :2] / n[..., 2:3]


def box(a: np.ndarray, k: int) -> np.ndarray:
    """Direct box average of (H, W, ...) over 2^k x 2^k blocks (H, W multiples of 2^k)."""
    f = 2**k
    h, w = a.shape[:2]
    return a.reshape(h // f, f, w // f, f, *a.shape[2:]).mean(axis=(1, 3))


# --- structure ------------------------------------------------------------------------------


@pytest.mark.parametrize("method", NORMAL_FILTERS)
def test_level_zero_is_exactly_the_source(method: str) -> None:
    rng = np.random.default_rng(RNG_SEED)
    n = decode_normal_map(rng.integers(0, 256, (12, 20, 3), dtype=np.uint8))
    r = rng.uniform(0.0, 1.0, (12, 20))
    chain = build_chain(n, r, method)
    np.testing.assert_array_equal(chain.normals[0], n.astype(np.float32))
    np.testing.assert_array_equal(chain.roughness[0], r.astype(np.float32))
    assert chain.normals[0].dtype == np.float32 and chain.roughness[0].dtype == np.float32
    flat = build_chain(n, 0.37, method)  # one roughness for every texel
    np.testing.assert_array_equal(flat.roughness[0], np.full((12, 20), 0.37, np.float32))


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (5, 7), (8, 8), (13, 3), (64, 1), (6, 33)])
def test_level_sizes_follow_gl(shape: tuple[int, int]) -> None:
    """h_k = max(1, h >> k) for k = 0 .. floor(log2(max(h, w))), as glGenerateMipmap."""
    h, w = shape
    expected = [(max(1, h >> k), max(1, w >> k)) for k in range(int(math.log2(max(h, w))) + 1)]
    n = bumpy_normals(shape, 0.2, 1)
    for method in NORMAL_FILTERS:
        chain = build_chain(n, 0.5, method)
        assert [a.shape[:2] for a in chain.normals] == expected
        assert [a.shape for a in chain.roughness] == expected
        assert all(a.shape[2] == 3 for a in chain.normals)


@pytest.mark.parametrize("method", NORMAL_FILTERS)
def test_odd_sizes_weigh_every_source_texel_equally(method: str) -> None:
    """5 x 7 -> 2 x 3 -> 1 x 1 (the odd row and column join the last pair): the 1x1 level is
    the method applied to the plain mean of the moments of all 35 source texels."""
    rng = np.random.default_rng(RNG_SEED + 1)
    n = bumpy_normals((5, 7), 0.2, 2)
    r = rng.uniform(0.05, 0.5, (5, 7))
    top_n = build_chain(n, r, method).normals[-1][0, 0]
    top_r = float(build_chain(n, r, method).roughness[-1][0, 0])
    mean_n = n.reshape(-1, 3).mean(axis=0)
    s = slopes(n).reshape(-1, 2)
    if method == "naive":
        want_n, want_a2 = mean_n / np.linalg.norm(mean_n), r.mean() ** 4
    elif method == "toksvig":
        want_n = mean_n / np.linalg.norm(mean_n)
        want_a2 = alpha2_toksvig((r**4).mean(), np.linalg.norm(mean_n))
    else:
        want_n = np.append(-s.mean(axis=0), 1.0)
        want_n /= np.linalg.norm(want_n)
        want_a2 = alpha2_from_slope_variance((r**4).mean(), s.var(axis=0).mean())
    np.testing.assert_allclose(top_n, want_n, rtol=0, atol=2e-7)
    assert abs(top_r**4 / want_a2 - 1.0) <= F32_REL


# --- flat maps ------------------------------------------------------------------------------


@pytest.mark.parametrize("method", NORMAL_FILTERS)
def test_flat_map_keeps_constant_roughness_at_every_level(method: str) -> None:
    """All normals (0, 0, 1) and one r: every level of every method has normal +Z and r
    itself (measured: bit-identical to float32(r) for these values)."""
    n = np.zeros((16, 24, 3))
    n[..., 2] = 1.0
    for r in (0.0, 0.045, 0.3, 0.5, 0.77, 1.0):
        chain = build_chain(n, r, method)
        for level_n, level_r in zip(chain.normals, chain.roughness, strict=True):
            np.testing.assert_array_equal(level_n, np.broadcast_to([0, 0, 1], level_n.shape))
            np.testing.assert_array_equal(level_r, np.float32(r))


def test_flat_map_with_varying_roughness() -> None:
    """A flat map with a roughness texture: no normal variance to move anywhere, so what
    holds is the box filter of each method's roughness quantity: naive averages r,
    toksvig and variance average alpha^2 = r^4 (|E[n]| = 1, sigma^2 = 0)."""
    rng = np.random.default_rng(RNG_SEED + 2)
    n = np.zeros((16, 16, 3))
    n[..., 2] = 1.0
    r = rng.uniform(0.0, 1.0, (16, 16))
    for method in NORMAL_FILTERS:
        chain = build_chain(n, r, method)
        for k in range(1, 5):
            if method == "naive":
                want = box(r, k)
                np.testing.assert_allclose(chain.roughness[k], want, rtol=2**-23)
            else:
                want = box(r**4, k)
                np.testing.assert_allclose(alpha2(chain.roughness[k]), want, rtol=F32_REL)


# --- bumps move into roughness --------------------------------------------------------------


@pytest.mark.parametrize("degrees", [2.0, 10.0, 25.0])
@pytest.mark.parametrize("r", [0.0, 0.3, 0.6])
def test_checkerboard_of_tilted_normals(degrees: float, r: float) -> None:
    """Normals at +-theta about x, alternating per texel; every level >= 1 sees both equally.

    Derivation for the variance method: slopes are (0, +tan theta) and (0, -tan theta), half
    each, so E[s] = 0, Var(s.y) = tan^2 theta, Var(s.x) = 0; the isotropic sigma^2 is their
    mean, tan^2(theta)/2, and alpha'^2 = alpha^2 + 2 sigma^2 = alpha^2 + tan^2 theta (not
    + 2 tan^2 theta: the whole variance is along one axis, and one roughness spreads it over
    two). Toksvig: |E[n]| = cos theta. Naive: r unchanged. All: the normal is +Z.
    """
    theta = math.radians(degrees)
    n = checkerboard((16, 16), theta)
    a2 = r**4
    chains = {m: build_chain(n, r, m) for m in NORMAL_FILTERS}
    s_phong = 2.0 / a2 - 2.0 if a2 > 0 else math.inf
    if a2 > 0:  # Toksvig's formula as printed, through the Blinn-Phong exponent
        ft = math.cos(theta) / (math.cos(theta) + s_phong * (1.0 - math.cos(theta)))
        toksvig_a2 = 2.0 / (ft * s_phong + 2.0)
    else:  # its limit as s -> infinity
        toksvig_a2 = 2.0 * (1.0 - math.cos(theta)) / (2.0 - math.cos(theta))
    variance_a2 = min(1.0, a2 + math.tan(theta) ** 2)
    for k in range(1, 5):
        for chain in chains.values():
            up = np.zeros(chain.normals[k].shape)
            up[..., 2] = 1.0
            np.testing.assert_allclose(chain.normals[k], up, rtol=0, atol=1e-7)
        np.testing.assert_array_equal(chains["naive"].roughness[k], np.float32(r))
        got_t = alpha2(chains["toksvig"].roughness[k])
        got_v = alpha2(chains["variance"].roughness[k])
        np.testing.assert_allclose(got_t, toksvig_a2, rtol=F32_REL)
        np.testing.assert_allclose(got_v, variance_a2, rtol=F32_REL)
        assert np.all(got_t > a2) and np.all(got_v > a2)


def test_checkerboard_steep_enough_saturates_variance() -> None:
    """tan^2(60 deg) = 3 > 1 - alpha^2: alpha'^2 clamps at 1 (r' = 1)."""
    chain = build_chain(checkerboard((8, 8), math.radians(60.0)), 0.3, "variance")
    for level in chain.roughness[1:]:
        np.testing.assert_array_equal(level, np.float32(1.0))


def test_variance_method_conserves_the_slope_second_moment() -> None:
    """Law of total variance: the mean of the level-1 variances plus the variance of the
    level-1 mean slopes is the variance over the level-2 footprint. So level 2 built from
    level 1's own outputs (alpha'^2 = E[alpha_1'^2] + 2 Var_iso(slope of n_1), n_1's slope
    being E[s] exactly) equals level 2 from the source's 4x4 footprints (numpy's var).
    Slopes N(0, 0.12^2), r in [0.05, 0.35]: alpha'^2 stays < 1 (no clamp)."""
    rng = np.random.default_rng(RNG_SEED + 3)
    n = bumpy_normals((32, 32), 0.12, 3)
    r = rng.uniform(0.05, 0.35, (32, 32))
    chain = build_chain(n, r, "variance")
    assert max(float(level.max()) for level in chain.roughness) < 1.0
    s = slopes(n)
    for k in (1, 2, 3):
        f = 2**k
        foot = s.reshape(32 // f, f, 32 // f, f, 2)
        var_iso = foot.var(axis=(1, 3)).mean(axis=-1)
        direct = box(r**4, k) + 2.0 * var_iso
        np.testing.assert_allclose(alpha2(chain.roughness[k]), direct, rtol=F32_REL)
        mean_slope = foot.mean(axis=(1, 3))
        got_slope = slopes(chain.normals[k].astype(np.float64))
        np.testing.assert_allclose(got_slope, mean_slope, rtol=0, atol=1e-6)
    # Level 2 from level 1's outputs alone.
    a2_1 = alpha2(chain.roughness[1])
    s_1 = slopes(chain.normals[1].astype(np.float64))
    foot = s_1.reshape(8, 2, 8, 2, 2)
    from_level1 = box(a2_1, 1) + 2.0 * foot.var(axis=(1, 3)).mean(axis=-1)
    # Level 1 is float32 (its slopes carry ~1e-8 absolute): measured 2.0e-7 relative.
    np.testing.assert_allclose(alpha2(chain.roughness[2]), from_level1, rtol=F32_REL)


def test_toksvig_closed_form_matches_the_printed_formula() -> None:
    """alpha2_toksvig's rearrangement (no Blinn-Phong exponent, finite at alpha = 0) equals
    ft = |Na|/(|Na| + s(1 - |Na|)), alpha'^2 = 2/(ft s + 2), s = 2/alpha^2 - 2, to 1e-12."""
    a2, na = np.meshgrid(np.linspace(0.001, 0.999, 101), np.linspace(0.01, 1.0, 100))
    s = 2.0 / a2 - 2.0
    ft = na / (na + s * (1.0 - na))
    np.testing.assert_allclose(alpha2_toksvig(a2, na), 2.0 / (ft * s + 2.0), rtol=1e-12)
    assert alpha2_toksvig(0.0, 1.0) == 0.0 and alpha2_toksvig(1.0, 0.3) == 1.0
    assert alpha2_toksvig(1.0, 0.0) == 1.0  # the 0/0 corner
    assert np.all(alpha2_toksvig(a2, na) >= a2 - 1e-15)  # never sharper


# --- robustness -----------------------------------------------------------------------------


@pytest.mark.parametrize("method", NORMAL_FILTERS)
def test_grazing_normals_and_extreme_roughness_stay_finite(method: str) -> None:
    """Normals at n.z = 0, 1e-300, 1e-8, MIN_NORMAL_Z/2 and 1, opposite horizontal pairs
    (whose mean vanishes), r in {0, 1}: every level finite, unit normals, r' in [0, 1]."""
    rng = np.random.default_rng(RNG_SEED + 4)
    h, w = 16, 16
    z = rng.choice([0.0, 1e-300, 1e-8, MIN_NORMAL_Z / 2, 1.0], (h, w))
    phi = rng.uniform(0.0, 2.0 * np.pi, (h, w))
    rho = np.sqrt(1.0 - z * z)
    n = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)
    n[:4, :4] = [1.0, 0.0, 0.0]  # a 4x4 block of +x and -x columns: E[n] = 0
    n[:4, 1:4:2] = [-1.0, 0.0, 0.0]
    for r in (np.zeros((h, w)), np.ones((h, w)), rng.choice([0.0, 1.0], (h, w))):
        chain = build_chain(n, r, method)
        for level_n, level_r in zip(chain.normals, chain.roughness, strict=True):
            assert np.all(np.isfinite(level_n)) and np.all(np.isfinite(level_r))
            np.testing.assert_allclose(np.linalg.norm(level_n, axis=-1), 1.0, atol=1e-6)
            assert level_r.min() >= 0.0 and level_r.max() <= 1.0


def test_decode_normal_map() -> None:
    """v/255*2 - 1 per channel, normalised; z floored at MIN_NORMAL_Z with unit length kept;
    RGBA reads as RGB; the 8-bit round trip of unit normals is within half a code."""
    rgb = np.array([[[128, 128, 255], [255, 128, 128], [0, 0, 0], [10, 250, 130]]], np.uint8)
    n = decode_normal_map(rgb)
    assert n.shape == (1, 4, 3) and n.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-15)
    flat = np.array([1.0, 1.0, 255.0]) / 255.0
    np.testing.assert_allclose(n[0, 0], flat / np.linalg.norm(flat), atol=1e-15)
    np.testing.assert_allclose(n[0, 1:, 2], MIN_NORMAL_Z, atol=1e-15)
    rgba = np.concatenate([rgb, np.full((1, 4, 1), 7, np.uint8)], axis=-1)
    np.testing.assert_array_equal(decode_normal_map(rgba), n)
    # Round trip: encode unit normals with z >= 0.2 to 8 bits, decode; each channel is off by
    # at most half a code (1/255) before normalising, so the angle is below ~1/255 * sqrt(3).
    m = bumpy_normals((64, 64), 0.5, 5)
    m = m[m[..., 2] >= 0.2][None]
    back = decode_normal_map(np.round((m * 0.5 + 0.5) * 255.0).astype(np.uint8))
    angle = np.arccos(np.clip(np.sum(back * m, axis=-1), -1.0, 1.0))
    assert angle.max() < math.sqrt(3.0) / 255.0


@pytest.mark.parametrize(
    ("normals", "roughness", "method"),
    [
        (np.dstack([np.zeros((4, 4, 2)), np.ones((4, 4))]), 0.5, "trilinear"),
        (np.dstack([np.zeros((4, 4, 2)), np.ones((4, 4))]), np.zeros((4, 5)), "variance"),
        (np.dstack([np.zeros((4, 4, 2)), np.ones((4, 4))]), 1.5, "variance"),
        (np.dstack([np.zeros((4, 4, 2)), np.ones((4, 4))]), math.nan, "toksvig"),
        (np.dstack([np.zeros((4, 4, 2)), np.full((4, 4), 2.0)]), 0.5, "naive"),
        (np.zeros((4, 4, 2)), 0.5, "naive"),
    ],
)
def test_bad_arguments_raise(normals: np.ndarray, roughness: object, method: str) -> None:
    with pytest.raises(ValueError):
        build_chain(normals, roughness, method)  # type: ignore[arg-type]


@pytest.mark.parametrize("rgb", [np.zeros((4, 4, 3), np.float32), np.zeros((4, 4), np.uint8)])
def test_decode_rejects_non_uint8_rgb(rgb: np.ndarray) -> None:
    with pytest.raises(ValueError):
        decode_normal_map(rgb)


def test_box_mips_are_exact_footprint_means() -> None:
    """Scalar and colour maps (masks, metallic, baked colour): level 0 is the source, and
    every texel of every level is the mean of the source texels under its footprint, odd
    sizes included (a 7-wide level's last texel covers three)."""
    rng = np.random.default_rng(11)
    values = rng.uniform(0.0, 1.0, (6, 7, 3))
    levels = box_mips(values)
    np.testing.assert_array_equal(levels[0], values.astype(np.float32))
    assert [lv.shape[:2] for lv in levels] == [(6, 7), (3, 3), (1, 1)]
    np.testing.assert_allclose(levels[1][0, 2], values[0:2, 4:7].mean(axis=(0, 1)), rtol=1e-6)
    np.testing.assert_allclose(levels[2][0, 0], values.mean(axis=(0, 1)), rtol=1e-6)
    assert box_mips(values[..., 0])[2].shape == (1, 1)


@pytest.mark.parametrize("shape", [(12, 20), (7, 13), (1, 9), (33, 1), (5, 5)])
def test_fast_forms_match_the_textbook_forms_bit_for_bit(shape: tuple[int, int]) -> None:
    """The decode (a table of the 256 values, |n| summed by hand) and the block sums (two
    strided views, a block of three added in order) are the same float64 operations as
    v/255*2-1 over the texels, np.linalg.norm and np.add.reduceat: the same bits, so that
    the faster chain changes no pixel."""
    from app.textures.mips import _halve

    rgb = np.random.default_rng(RNG_SEED).integers(0, 256, (*shape, 3), dtype=np.uint8)
    textbook = rgb.astype(np.float64) * (2.0 / 255.0) - 1.0
    textbook /= np.linalg.norm(textbook, axis=-1, keepdims=True)
    low = textbook[..., 2] < MIN_NORMAL_Z
    xy = textbook[low, :2]
    scale = math.sqrt(1.0 - MIN_NORMAL_Z**2) / np.linalg.norm(xy, axis=-1, keepdims=True)
    textbook[low, :2] = xy * scale
    textbook[low, 2] = MIN_NORMAL_Z
    assert np.array_equal(decode_normal_map(rgb), textbook)
    values = np.random.default_rng(RNG_SEED + 1).random((*shape, 4))
    blocks = values
    for axis in (0, 1):
        starts = np.arange(0, 2 * max(1, blocks.shape[axis] // 2), 2)
        blocks = np.add.reduceat(blocks, starts, axis=axis)
    assert np.array_equal(_halve(values), blocks)


@pytest.mark.parametrize("shape", [(131, 37), (129, 6), (64, 9), (67, 1)])
def test_bands_give_the_bits_of_the_whole_map(
    shape: tuple[int, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The chain and the box mips are made ``BAND_ROWS`` rows at a time (an odd last row
    joining the band before it): every level equals, bit for bit, the one made from the
    whole map in one band, for taller-than-a-band maps with odd and even heights."""
    from app.textures import mips

    rng = np.random.default_rng(RNG_SEED + 7)
    n = decode_normal_map(rng.integers(0, 256, (*shape, 3), dtype=np.uint8))
    r = rng.uniform(0.0, 1.0, shape)
    values = rng.uniform(0.0, 1.0, (*shape, 2))
    monkeypatch.setattr(mips, "BAND_ROWS", 16)
    banded = {m: build_chain(n, r, m) for m in NORMAL_FILTERS}
    boxes = box_mips(values)
    monkeypatch.setattr(mips, "BAND_ROWS", 1 << 20)  # one band: the whole map
    for method, chain in banded.items():
        whole = build_chain(n, r, method)
        pairs = zip(chain.normals + chain.roughness, whole.normals + whole.roughness, strict=True)
        for a, b in pairs:
            assert a.tobytes() == b.tobytes(), method
    assert all(a.tobytes() == b.tobytes() for a, b in zip(boxes, box_mips(values), strict=True))


def test_bands_are_made_on_two_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    """A chain's bands are shared between the calling thread and a helper (the render
    waiting for the map leaves a core idle), with the bits of one thread's chain, and a
    band's exception is raised to the caller."""
    import threading
    import time

    from app.textures import mips

    rng = np.random.default_rng(RNG_SEED + 8)
    n = decode_normal_map(rng.integers(0, 256, (96, 20, 3), dtype=np.uint8))
    r = rng.uniform(0.0, 1.0, (96, 20))
    threads: set[str] = set()

    def source(y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
        threads.add(threading.current_thread().name)
        time.sleep(0.01)  # long enough that the helper takes a band too
        return n[y0:y1], r[y0:y1]

    monkeypatch.setattr(mips, "BAND_ROWS", 8)
    both = mips.chain_levels(source, (96, 20), "variance")
    assert len(threads) == 2, threads
    monkeypatch.setattr(mips, "BAND_THREADS", 1)
    one = mips.chain_levels(source, (96, 20), "variance")
    assert all(a.tobytes() == b.tobytes() for a, b in zip(both, one, strict=True))
    monkeypatch.setattr(mips, "BAND_THREADS", 2)

    def broken(y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
        if y0 == 40:
            raise ValueError("band 40")
        return n[y0:y1], r[y0:y1]

    with pytest.raises(ValueError, match="band 40"):
        mips.chain_levels(broken, (96, 20), "variance")


@pytest.mark.parametrize("shape", [(131, 37), (64, 9), (1, 5)])
def test_float16_levels_made_directly_are_the_cast_levels(
    shape: tuple[int, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``rows_up_float16`` (what a render uploads, without float32 copies of the levels):
    every level is the float16 cast of the float32 level, rows bottom first, bit for bit,
    for the chain (each method, and level 0 alone) and the box mips."""
    from app.textures import mips

    monkeypatch.setattr(mips, "BAND_ROWS", 16)
    rng = np.random.default_rng(RNG_SEED + 9)
    n = decode_normal_map(rng.integers(0, 256, (*shape, 3), dtype=np.uint8))
    r = rng.uniform(0.0, 1.0, shape)
    values = rng.uniform(0.0, 1.0, (*shape, 1))

    def source(y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
        return n[y0:y1], r[y0:y1]

    def same(made: list[np.ndarray], levels: list[np.ndarray]) -> bool:
        want = [mips.float16_rows_up(level) for level in levels]
        return len(made) == len(want) and all(
            a.dtype == np.float16 and a.tobytes() == b.tobytes()
            for a, b in zip(made, want, strict=True)
        )

    for method in NORMAL_FILTERS:
        for count in (None, 1):
            direct = mips.chain_levels(source, shape, method, count, rows_up_float16=True)
            assert same(direct, mips.chain_levels(source, shape, method, count)), method
    band = lambda y0, y1: values[y0:y1]  # noqa: E731
    direct = mips.box_levels(band, (*shape, 1), rows_up_float16=True)
    assert same(direct, mips.box_levels(band, (*shape, 1)))


def test_box_levels_float16_table_is_the_cast(monkeypatch: pytest.MonkeyPatch) -> None:
    """An 8-bit channel's float16 level 0 through ``unorm8_float16`` (what channel_texture
    gives box_levels) is the cast of its float64 values, bit for bit, for every 8-bit
    value, and so is every other level."""
    from app.textures import mips

    monkeypatch.setattr(mips, "BAND_ROWS", 16)
    rng = np.random.default_rng(RNG_SEED + 10)
    texels = rng.integers(0, 256, (37, 41), dtype=np.uint8)
    texels.reshape(-1)[:256] = np.arange(256)  # every value at least once
    band = lambda y0, y1: texels[y0:y1, :, None] / 255.0  # noqa: E731
    table = lambda y0, y1: mips.unorm8_float16(texels[y0:y1, :, None])  # noqa: E731
    direct = mips.box_levels(band, (37, 41, 1), rows_up_float16=True, float16_rows=table)
    cast = mips.box_levels(band, (37, 41, 1), rows_up_float16=True)
    assert len(direct) == len(cast)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(direct, cast, strict=True))


@pytest.mark.parametrize("shape", [(131, 37), (64, 9), (1, 5), (5, 1), (1, 1), (256, 256)])
def test_unorm8_box_levels_are_box_levels(
    shape: tuple[int, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """An 8-bit channel's levels from its integer sums (what channel_texture builds) are
    box_levels' of its float64 values v / 255, bit for bit: float32 and float16 rows up,
    from each first level, of a strided view like an image's storage, random texels
    and a map of one value."""
    from app.textures import mips

    monkeypatch.setattr(mips, "BAND_ROWS", 16)
    rng = np.random.default_rng(RNG_SEED + 11)
    storage = rng.integers(0, 256, (*shape, 4), dtype=np.uint8)
    for texels in (storage[..., 2], np.full(shape, 255, np.uint8)):
        band = lambda y0, y1, t=texels: t[y0:y1, :, None] / 255.0  # noqa: E731
        table = lambda y0, y1, t=texels: mips.unorm8_float16(t[y0:y1, :, None])  # noqa: E731
        for first in range(3):
            for rows_up in (False, True):
                want = mips.box_levels(band, (*shape, 1), rows_up, table, first)
                made = mips.unorm8_box_levels(texels, rows_up, first)
                assert [a.dtype for a in made] == [b.dtype for b in want]
                assert [a.shape for a in made] == [b.shape for b in want]
                assert all(a.tobytes() == b.tobytes() for a, b in zip(made, want, strict=True))


def test_unorm8_box_levels_every_level_one_sum() -> None:
    """Every sum a level-1 footprint of 4, 6 or 9 texels can hold (maps of 2x2, 2x3 and
    3x3: one footprint each), each split over its texels at random: level 1 is
    box_levels', bit for bit, where it divides in float32 and box_levels adds float64
    quotients."""
    from app.textures import mips

    rng = np.random.default_rng(RNG_SEED + 12)
    for shape in ((2, 2), (2, 3), (3, 3)):
        n = shape[0] * shape[1]
        for total in range(255 * n + 1):
            texels = np.full(n, total // n)
            texels[: total % n] += 1
            for i, j in rng.integers(0, n, (2 * n, 2)):  # moved between texels, each <= 255
                if i != j:
                    texels[i], texels[j] = _moved(rng, texels[i], texels[j])
            assert texels.sum() == total and texels.max() <= 255
            t = texels.reshape(shape).astype(np.uint8)
            band = lambda y0, y1, t=t: t[y0:y1, :, None] / 255.0  # noqa: E731
            for rows_up in (False, True):
                (want,) = mips.box_levels(band, (*shape, 1), rows_up, None, 1)
                (made,) = mips.unorm8_box_levels(t, rows_up, 1)
                assert made.tobytes() == want.tobytes(), (shape, total)


def _moved(rng: np.random.Generator, a: int, b: int) -> tuple[int, int]:
    """Some of ``a`` moved to ``b`` (at most what keeps ``b`` <= 255)."""
    amount = int(rng.integers(0, min(a, 255 - b) + 1))
    return a - amount, b + amount


def test_decode_normal_planes() -> None:
    """``planes=True``: the same bits as the interleaved decode (the z floor included),
    each component a contiguous plane that the chain's moments read."""
    rgb = np.random.default_rng(RNG_SEED).integers(0, 256, (33, 47, 3), np.uint8)
    rgb[::3, :, 2] = 120  # n.z < MIN_NORMAL_Z: floored
    held = decode_normal_map(rgb, planes=True)
    whole = decode_normal_map(rgb)
    assert (held[..., 2] == MIN_NORMAL_Z).any()
    np.testing.assert_array_equal(held.view(np.int64), whole.view(np.int64))
    assert all(held[..., k].flags.c_contiguous for k in range(3))


def test_variance_texels_bits() -> None:
    """The variance method's texels a plane at a time (``_variance_texels``, what the
    chain's levels 1 and up are made with): the bits of ``_filtered``'s."""
    from app.textures.mips import _filtered, _variance_texels

    rng = np.random.default_rng(RNG_SEED)
    sx, sy = rng.normal(0.0, 2.0, (2, 40, 30))
    m = {
        "sx": sx,
        "sy": sy,
        "sxx": sx * sx + rng.uniform(0.0, 3.0, sx.shape),
        "syy": sy * sy + rng.uniform(0.0, 3.0, sx.shape),
        "a2": rng.uniform(0.0, 1.0, sx.shape) ** 4,
    }
    normal, r = _filtered("variance", m)
    out = np.empty((40, 30, 4))
    _variance_texels(m, out)
    np.testing.assert_array_equal(out[..., :3].view(np.int64), normal.view(np.int64))
    np.testing.assert_array_equal(out[..., 3].view(np.int64), r.view(np.int64))


def test_srgb_tables_are_the_formulas() -> None:
    """``srgb_tables``: the decode table is IEC 61966-2-1's decode of every 8-bit code in
    units of 1/65535, and the table made from the codes' steps is the encode of the mean,
    rounded, at every one of the 262,141 sums of four (the formula the steps stand for)."""
    from app.reference.tonemap import srgb_decode, srgb_encode
    from app.textures import mips

    linear16, of_sum4 = mips.srgb_tables()
    codes = np.arange(256) / 255.0
    assert np.array_equal(linear16, np.round(srgb_decode(codes) * 65535.0).astype(np.uint32))
    sums = np.arange(mips.SUM4 + 1)
    want = np.round(srgb_encode(sums / float(mips.SUM4)) * 255.0).astype(np.uint8)
    assert of_sum4.dtype == np.uint8 and np.array_equal(of_sum4, want)


@pytest.mark.parametrize("pattern", ["random", "sparse"])
@pytest.mark.parametrize("side", [1, 2, 64, 256])
def test_srgb_box_levels_in_bands_are_the_whole_levels(
    side: int, pattern: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A DCT-scaled colour map's CPU mips, made a band of rows at a time, are the bits of
    the whole level's arithmetic (each texel: the 2x2 box of the level above in linear
    space through the same two tables, alpha averaged and rounded as it is), whatever
    the band size (one output row a band, and one band for the whole level). "sparse" is
    an emission map's kind: black and opaque but for a few texels, with a block of one
    translucent colour, so that most bands hold one texel value (boxed once)."""
    from app.textures import mips

    rng = np.random.default_rng(side)
    texels = rng.integers(0, 256, (side, side, 4), np.uint8)
    if pattern == "sparse":
        lit = texels[rng.integers(0, side, 3), rng.integers(0, side, 3)]
        texels[:] = (0, 0, 0, 255)
        texels[rng.integers(0, side, 3), rng.integers(0, side, 3)] = lit
        texels[side // 2 :, : side // 2] = (200, 90, 17, 77)
    uniform = mips._uniform_texel
    boxed_once: list[bool] = []
    monkeypatch.setattr(
        mips, "_uniform_texel", lambda b: boxed_once.append((t := uniform(b)) is not None) or t
    )
    expected = [texels]
    while expected[-1].shape[0] > 1:
        above = expected[-1]
        linear = mips.srgb_tables()[0][above[..., :3].astype(np.int64)]
        total = linear[0::2, 0::2] + linear[1::2, 0::2] + linear[0::2, 1::2] + linear[1::2, 1::2]
        alpha = above[..., 3].astype(np.int64)
        box = alpha[0::2, 0::2] + alpha[1::2, 0::2] + alpha[0::2, 1::2] + alpha[1::2, 1::2]
        level = np.empty((above.shape[0] // 2, above.shape[1] // 2, 4), np.uint8)
        level[..., :3] = mips.srgb_tables()[1][total]
        level[..., 3] = (box + 2) // 4
        expected.append(level)
    for band_texels in (1, 1 << 20):
        monkeypatch.setattr(mips, "SRGB_BAND_TEXELS", band_texels)
        made = mips.srgb_box_levels(texels)
        assert len(made) == len(expected) == side.bit_length()
        assert made[0] is texels
        for k, (a, b) in enumerate(zip(made, expected, strict=True)):
            assert a.dtype == np.uint8 and a.shape == b.shape, k
            assert np.array_equal(a, b), k
    if pattern == "sparse" and side >= 64:  # the one-texel path taken, and held to the bits
        assert any(boxed_once)
