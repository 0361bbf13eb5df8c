"""The GL's normal/roughness chain, function by function (RTR4 §9.13): glsl/material/chain.glsl
against its float64 twin app/reference/chain.py and glsl/common/footprint.glsl against
app/reference/footprint.py, on EGL and OSMesa; and the twins against what they stand for,
the footprints of footprint_starts/footprint_means and the float64 ``variance`` chain of
app/textures/mips.py.

GLSL-vs-twin: the twin gets the float32 inputs the shader received, so what is left is the
shader's float32 arithmetic. U = 2^-24 is a rounding's relative error; a division counts 2
(llvmpipe may form a / b as a * (1 / b)), inversesqrt 4 (the GLSL specification's 2 ulp,
an ulp 2 U in [1, 2)), sqrt 1. Each bound below is twice the count, for the compiler's
freedom to contract a * b + c into one fused operation or keep it as two.

* footprint_last_child, footprint_texels: integer arithmetic, compared exactly (every value
  is an integer well below 2^24, so the float result is exact too).
* chain_normal, absolute on the unit components: unorm * 2 - 1 (1 rounding), normalize (a
  dot product of 3 terms, 3; inversesqrt, 4; the product, 1): 8 U per component; the floor
  rescales n.xy by sqrt(1 - f^2) / |n.xy| (|n.xy| 4, the constant 1, the division 2, the
  product 1: 8 more; n.xy's own errors scale with it), and the normal scale multiplies
  (1) and normalizes again (8 on a vector whose components carry up to 16): 8 + 8 + 9 =
  25 U counted, 50 U = 3.0e-6 asserted. Where float32's n.z and float64's fall on two
  sides of the floor the branches differ, but the floored normal is continuous there.
* chain_slope, relative per component: one division (2 U) and the floor constant, 0.05 in
  float32 (0.25 U above the float64 one): 2.25 U counted, 4.5 U asserted.
* chain_merge: weight, one sum (1 U relative); mean, absolute against S = max(|mean|,
  |s|): d = s - mean (1 U of |d| <= 2 S), w / total (2), the product (1) and the sum (1 U
  of |mean'| <= S): 2 + 2 + 1 + 1 = 6 U S counted; deviations, relative (every term >= 0,
  so relative errors do not grow): v w (1), |d|^2 (d's 2, the dot product's 2), W w / total
  (1 + 2), their product (1), two sums (2): 9 U counted; alpha^2 (a product and a sum,
  terms >= 0): 2 U counted.
* chain_block4: mean, absolute: ((s0 + s1) + (s2 + s3)) / 4, three sums, <= 2 U max|s_i|
  (the last sum's rounding is relative to a sum up to 4 max|s_i|, before the exact / 4).
  Deviations: the four d_i = s_i - mean sum to 0, so the mean's error e shifts them with
  no first-order effect: sum (d_i - e)^2 = sum d_i^2 + 4 e^2, <= 8 U^2 S^2 of the result
  over both axes (after / 4); the rest, terms >= 0: d_i (1), its square (1), the dot
  product's sum (1), + v_i (1), three sums (3): 7 U relative counted. Weight 1 and alpha^2
  pass through: exact.
* chain_stored: the mean passes through (exact); deviations / weight and alpha^2 / weight,
  a division each: 2 U relative counted.
* chain_texel: the normal of (-s, 1), normalize as above: 8 U absolute counted; r: alpha^2
  + max(var, 0) (1 U, terms >= 0), min (exact), then two square roots (each halves the
  error before it and adds 1 U): 1/4 + 1/2 + 1 = 1.75 U relative counted.
* chain_empty and CHAIN_MIN_NORMAL_Z: exact (zeros; the constant as float32 rounds 0.05).

Twins against what they claim: exact integers for the footprints; for the chain, the float64
moments of mips.py's sums (E[s^2] - E[s]^2) and the twins' merges (Chan et al.'s update) are
one box filter done two ways, so they differ by float64 roundings alone: asserted 1e-13
(measured 1.4e-15), on maps whose footprints have a real spread of slopes, where r =
alpha'^(1/4) is well conditioned (a footprint of equal slopes and roughness 0 can leave
mips.py a variance of rounding, E[s^2] - E[s]^2 ~ 1e-16 s^2, whose fourth root is ~1e-4);
against the float32 levels mips.py makes of them, that plus their rounding, U |value|.

Measured on llvmpipe, EGL and OSMesa alike (the largest error, in U): chain_normal 2.2 (of
50), chain_slope 1.25 (of 4.5); chain_merge weight 1.0 (of 2), mean 3.8 (of 12), deviations
3.8 (of 18), alpha^2 1.7 (of 4); chain_block4 mean 1.7 (of 4), deviations a quarter of
their bound; chain_stored 0.98 (of 4); chain_texel normal 2.2 (of 16), r 1.3 (of 3.5); the
footprints, chain_empty, the constant and the pass-through fields exact.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.gl.context import GLContext
from app.gl.kernel import run_kernel
from app.reference.chain import (
    CHAIN_MIN_NORMAL_Z,
    ChainMoments,
    chain_block4,
    chain_empty,
    chain_merge,
    chain_normal,
    chain_slope,
    chain_stored,
    chain_texel,
)
from app.reference.footprint import (
    footprint_last_child,
    footprint_means,
    footprint_starts,
    footprint_texels,
)
from app.textures.mips import (
    MIN_NORMAL_Z,
    _filtered,
    _halve,
    _halve_counts,
    _moment,
    chain_levels,
    decode_normal_map,
)
from tests.agreement import relative_error

CHAIN = ["material/chain.glsl"]
FOOTPRINT = ["common/footprint.glsl"]
RNG_SEED = 20250614
U = 2.0**-24
NORMAL_ABS = 50 * U
SLOPE_REL = 4.5 * U
MERGE_WEIGHT_REL = 2 * U
MERGE_MEAN_ABS = 12 * U  # times S = max(|mean|, |s|)
MERGE_DEVIATIONS_REL = 18 * U
MERGE_ALPHA2_REL = 4 * U
BLOCK_MEAN_ABS = 4 * U  # times max |s_i|
BLOCK_DEVIATIONS_REL = 14 * U
BLOCK_DEVIATIONS_ABS = 16 * U * U  # times max |s_i|^2
STORED_REL = 4 * U
TEXEL_NORMAL_ABS = 16 * U
TEXEL_R_REL = 3.5 * U
CHAIN_LEVELS_ABS = 1e-13  # float64 roundings between mips.py's sums and the twins' merges


def f32(a: np.ndarray) -> np.ndarray:
    """The float32 value the shader receives, back in float64 for the twin."""
    return np.asarray(a, np.float32).astype(np.float64)


def check(gl: GLContext, name: str, error: np.ndarray, bound: float) -> None:
    """Assert the largest error within ``bound``, printing it (``pytest -s``) in units of
    the bound's own scale."""
    worst = float(np.max(error))
    print(f"{gl.backend} {name}: {worst:.3e} (bound {bound:.3e})")
    assert worst <= bound, f"{name}: {worst:.3e} > bound {bound:.3e}"


# --- footprint.glsl ------------------------------------------------------------------------

FOOTPRINT_BODY = """
result = vec4(float(footprint_last_child(int(c.x), int(c.y), int(c.z))),
              footprint_texels(int(t.x), int(t.y), int(t.z), int(t.w)), 0.0, 0.0);
"""


def _footprint_cases() -> tuple[np.ndarray, np.ndarray]:
    """(i, n, size) rows for footprint_last_child and (i, k, size, n0) rows for
    footprint_texels: every texel of every level of sides 1 .. 70, and of long sides
    (odd, even, powers of two and one past) their first, second, last two and random
    texels; two levels past a side's 1x1 too (a side of 1 under a longer other side). The
    two sets are cut to one length (the kernel runs them side by side)."""
    rng = np.random.default_rng(RNG_SEED)
    child, texels = [], []
    for n0 in [*range(1, 71), 1023, 1024, 1025, 4095, 4097, 8192, 12345]:
        for k in range(n0.bit_length() + 2):
            size = max(1, n0 >> k)
            if size <= 70:
                i = np.arange(size)
            else:
                i = np.unique(np.r_[0, 1, size - 2, size - 1, rng.integers(0, size, 8)])
            texels += [(x, k, size, n0) for x in i]
            if k >= 1:
                n = max(1, n0 >> (k - 1))
                child += [(x, n, size) for x in i]
    rows = min(len(child), len(texels))
    return np.array(child[:rows], np.float64), np.array(texels[:rows], np.float64)


def test_footprint_glsl_matches_twin_exactly(gl: GLContext) -> None:
    """footprint_last_child and footprint_texels, on every texel of every level of sides
    1 .. 70 (odd and even, size-1 sides, last texels) and on long sides: the same integers
    as their twins."""
    child, texels = _footprint_cases()
    assert len(child) > 2000
    out = run_kernel(gl.ctx, FOOTPRINT, FOOTPRINT_BODY, {"c": child, "t": texels})
    want_child = footprint_last_child(*(child[:, j].astype(np.int64) for j in range(3)))
    want_texels = footprint_texels(*(texels[:, j].astype(np.int64) for j in range(4)))
    np.testing.assert_array_equal(out[:, 0], want_child)
    np.testing.assert_array_equal(out[:, 1], want_texels)


@pytest.mark.parametrize("n0", [*range(1, 40), 64, 65, 127, 1000, 1023, 1025])
def test_footprint_texels_partition_level0(n0: int) -> None:
    """At every level, footprint_texels are the lengths of footprint_starts' footprints:
    they sum to n0 and lay every level-0 texel in exactly one footprint (two levels past the
    side's 1x1 too, where a longer other side goes on)."""
    for k in range(n0.bit_length() + 2):
        size = max(1, n0 >> k)
        counts = footprint_texels(np.arange(size), k, size, n0)
        starts = footprint_starts(n0, k)
        assert counts.sum() == n0
        np.testing.assert_array_equal(counts, np.diff(np.append(starts, n0)))
        owner = np.repeat(np.arange(size), counts.astype(np.int64))
        np.testing.assert_array_equal(np.searchsorted(starts, np.arange(n0), "right") - 1, owner)


@pytest.mark.parametrize("n0", [*range(1, 40), 64, 65, 127, 1000, 1023, 1025])
def test_footprint_children_tile_the_level_before(n0: int) -> None:
    """The children min(2 i, n - 1) .. footprint_last_child of consecutive texels of level
    k tile level k - 1 (first 0, last n - 1, each starting after the one before), and
    their footprints add up to their parent's."""
    for k in range(1, n0.bit_length() + 2):
        n, size = max(1, n0 >> (k - 1)), max(1, n0 >> k)
        i = np.arange(size)
        first = np.minimum(2 * i, n - 1)
        last = footprint_last_child(i, n, size)
        assert first[0] == 0 and last[-1] == n - 1
        np.testing.assert_array_equal(first[1:], last[:-1] + 1)
        child_texels = footprint_texels(np.arange(n), k - 1, n, n0)
        sums = np.array([child_texels[a : b + 1].sum() for a, b in zip(first, last, strict=True)])
        np.testing.assert_array_equal(sums, footprint_texels(i, k, size, n0))


def children(i: int, n: int, size: int) -> range:
    """The texels of level k - 1 (a side of ``n``) under texel ``i`` of level k (a side of
    ``size``), as normal_chain.frag loops over them."""
    return range(min(2 * i, n - 1), int(footprint_last_child(i, n, size)) + 1)


@pytest.mark.parametrize("shape", [(37, 29), (1, 9), (12, 1), (5, 5), (16, 8)])
def test_footprint_means_are_the_children_weighed_by_their_texels(shape: tuple[int, int]) -> None:
    """footprint_means' level k is its level k - 1 merged as the GL merges it: each texel
    the children under it (footprint_last_child) weighed by the level-0 texels each covers
    (footprint_texels), to float64's rounding."""
    h, w = shape
    levels = footprint_means(np.random.default_rng(sum(shape)).uniform(-1.0, 1.0, (h, w, 2)))
    for k in range(1, len(levels)):
        child, level = levels[k - 1], levels[k]
        (hc, wc), (hk, wk) = child.shape[:2], level.shape[:2]
        assert (hk, wk) == (max(1, h >> k), max(1, w >> k))
        merged = np.zeros_like(level)
        for y in range(hk):
            for x in range(wk):
                ys, xs = children(y, hc, hk), children(x, wc, wk)
                wy = footprint_texels(np.array(ys), k - 1, hc, h)
                wx = footprint_texels(np.array(xs), k - 1, wc, w)
                weights = wy[:, None] * wx[None, :]
                block = child[ys.start : ys.stop, xs.start : xs.stop]
                merged[y, x] = np.sum(block * weights[..., None], axis=(0, 1)) / weights.sum()
        np.testing.assert_allclose(merged, level, rtol=0, atol=1e-14)


# --- chain.glsl: each function against its twin -------------------------------------------


def test_constant_is_one_value(gl: GLContext) -> None:
    """CHAIN_MIN_NORMAL_Z in the GLSL is the twin's 0.05 rounded to float32, and the CPU
    chain's floor (app/textures/mips.py MIN_NORMAL_Z) is the twin's."""
    out = run_kernel(gl.ctx, CHAIN, "result = vec4(CHAIN_MIN_NORMAL_Z);", {"p": np.zeros(4)})
    np.testing.assert_array_equal(out, np.float32(CHAIN_MIN_NORMAL_Z))
    assert MIN_NORMAL_Z == CHAIN_MIN_NORMAL_Z


def normal_inputs(n: int = 6000) -> np.ndarray:
    """(unorm x, y, z, scale) rows: every texel of channels in {0, 1, 127, 128, 254, 255}
    (the unorm extremes, the values nearest a zero channel), random texels over the whole
    cube (half of them facing into the surface: the n.z floor), random upper-hemisphere
    texels, and texels whose n.z lies within 0.02 of the floor; the normal scale 1 for half
    the rows, else 0, 10 or uniform in [0, 3]."""
    rng = np.random.default_rng(RNG_SEED)
    edges = np.array([0, 1, 127, 128, 254, 255])
    corners = np.stack(np.meshgrid(edges, edges, edges, indexing="ij"), -1).reshape(-1, 3)
    anywhere = rng.integers(0, 256, (n // 2, 3))
    upper = rng.integers(0, 256, (n // 4, 3))
    upper[:, 2] = rng.integers(128, 256, n // 4)
    many = rng.integers(0, 256, (40 * n, 3))
    v = many * (2.0 / 255.0) - 1.0
    z = v[:, 2] / np.linalg.norm(v, axis=-1)
    near = many[np.abs(z - CHAIN_MIN_NORMAL_Z) < 0.02][: n // 4]
    texels = np.concatenate([corners, anywhere, upper, near]).astype(np.float64)
    rows = len(texels)
    scale = np.where(rng.uniform(size=rows) < 0.5, 1.0, rng.uniform(0.0, 3.0, rows))
    scale[1::16] = 0.0
    scale[3::16] = 10.0
    scale[: len(corners)] = 1.0
    scale[len(corners) : 2 * len(corners)] = 1.7  # the corners again, scaled
    texels[len(corners) : 2 * len(corners)] = corners
    return f32(np.column_stack([texels / 255.0, scale]))


def test_chain_normal_glsl_matches_twin(gl: GLContext) -> None:
    """chain_normal on unorm extremes, steep texels (the floor), a normal scale != 1:
    within 50 U absolute of the twin per component (docstring); and unit length."""
    u = normal_inputs()
    out = run_kernel(gl.ctx, CHAIN, "result = vec4(chain_normal(u.xyz, u.w), 0.0);", {"u": u})
    ref = chain_normal(u[:, :3], u[:, 3])
    v = u[:, :3] * 2.0 - 1.0
    floored = v[:, 2] / np.linalg.norm(v, axis=-1) < CHAIN_MIN_NORMAL_Z
    assert floored.sum() > 1000 and (u[:, 3] != 1.0).sum() > 2000
    assert np.allclose(np.linalg.norm(ref, axis=-1), 1.0, atol=1e-15)
    check(gl, "chain_normal", np.abs(out[:, :3] - ref), NORMAL_ABS)


def test_chain_slope_glsl_matches_twin(gl: GLContext) -> None:
    """chain_slope on unit normals all round the sphere (n.z from -1 to 1, many near the
    floor, n.z exactly 0, 1, -1 and the float32 floor): within 4.5 U relative per
    component (docstring)."""
    rng = np.random.default_rng(RNG_SEED + 1)
    n = 6000
    z = np.concatenate([rng.uniform(-1.0, 1.0, n // 2), rng.uniform(0.03, 0.07, n // 2)])
    z[:4] = [0.0, 1.0, -1.0, np.float32(CHAIN_MIN_NORMAL_Z)]
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    rho = np.sqrt(1.0 - z * z)
    normals = f32(np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z]))
    out = run_kernel(gl.ctx, CHAIN, "result = vec4(chain_slope(n.xyz), 0.0, 0.0);", {"n": normals})
    ref = chain_slope(normals)
    assert (normals[:, 2] < CHAIN_MIN_NORMAL_Z).sum() > 2000
    assert np.abs(ref).max() <= 1.0 / CHAIN_MIN_NORMAL_Z
    check(gl, "chain_slope", relative_error(out[:, :2], ref, 1e-30), SLOPE_REL)


def test_chain_empty_glsl_is_zero(gl: GLContext) -> None:
    """chain_empty: every field 0, as the twin's."""
    body = """
    ChainMoments m = chain_empty();
    result = p.x < 0.5 ? vec4(m.weight, m.mean, m.deviations) : vec4(m.alpha2);
    """
    out = run_kernel(gl.ctx, CHAIN, body, {"p": np.array([0.0, 1.0])})
    m = chain_empty()
    np.testing.assert_array_equal(out[0], [m.weight, *m.mean, m.deviations])
    np.testing.assert_array_equal(out[1], m.alpha2)


MERGE_BODY = """
ChainMoments m = chain_merge(ChainMoments(a.x, a.yz, a.w, b.x), b.y, s.xy, b.z, b.w);
result = c.x < 0.5 ? vec4(m.weight, m.mean, m.deviations) : vec4(m.alpha2);
"""


def merge_inputs(n: int = 6000) -> dict[str, np.ndarray]:
    """A running merge (weight W, mean, deviations, alpha^2) and a part (w, s, v, a2):
    W 0 for an eighth of the rows (the first merge, from chain_empty), else integer
    footprint sizes up to 2^20 or real weights in [0.1, 1e4], w alike; means and slopes in
    [-20, 20], a quarter of the parts' slopes within 1e-4 of the mean; variances in
    [0, 800] (a quarter 0), alpha^2 in [0, 1]."""
    rng = np.random.default_rng(RNG_SEED + 2)

    def weights() -> np.ndarray:
        integer = rng.integers(1, 2**20, n).astype(np.float64)
        return np.where(rng.uniform(size=n) < 0.5, integer, rng.uniform(0.1, 1e4, n))

    big_w, w = weights(), weights()
    big_w[::8] = 0.0
    mean = rng.uniform(-20.0, 20.0, (n, 2))
    mean[::8] = 0.0
    s = rng.uniform(-20.0, 20.0, (n, 2))
    s[1::4] = mean[1::4] + rng.uniform(-1e-4, 1e-4, (len(s[1::4]), 2))
    v = rng.uniform(0.0, 800.0, n)
    v[2::4] = 0.0
    deviations = big_w * rng.uniform(0.0, 800.0, n)
    alpha2 = big_w * rng.uniform(0.0, 1.0, n)
    return {
        "a": f32(np.column_stack([big_w, mean, deviations])),
        "b": f32(np.column_stack([alpha2, w, v, rng.uniform(0.0, 1.0, n)])),
        "s": f32(s),
    }


def test_chain_merge_glsl_matches_twin(gl: GLContext) -> None:
    """chain_merge: weight within 2 U, mean within 12 U of max(|mean|, |s|), deviations
    within 18 U and alpha^2 within 4 U relative (docstring)."""
    x = merge_inputs()
    a, b, s = x["a"], x["b"], x["s"]
    rows = len(a)
    first = run_kernel(gl.ctx, CHAIN, MERGE_BODY, {**x, "c": np.zeros(rows)})
    second = run_kernel(gl.ctx, CHAIN, MERGE_BODY, {**x, "c": np.ones(rows)})
    m = chain_merge(
        ChainMoments(a[:, 0], a[:, 1:3], a[:, 3], b[:, 0]), b[:, 1], s, b[:, 2], b[:, 3]
    )
    scale = np.maximum(np.abs(a[:, 1:3]).max(axis=-1), np.abs(s).max(axis=-1))
    check(gl, "chain_merge weight", relative_error(first[:, 0], m.weight, 1e-30), MERGE_WEIGHT_REL)
    mean_error = np.abs(first[:, 1:3] - m.mean).max(axis=-1) / scale
    check(gl, "chain_merge mean", mean_error, MERGE_MEAN_ABS)
    deviations_error = relative_error(first[:, 3], m.deviations, 1e-30)
    check(gl, "chain_merge deviations", deviations_error, MERGE_DEVIATIONS_REL)
    check(gl, "chain_merge alpha2", relative_error(second[:, 0], m.alpha2, 1e-30), MERGE_ALPHA2_REL)


BLOCK_BODY = """
ChainMoments m = chain_block4(vec2[4](s01.xy, s01.zw, s23.xy, s23.zw),
                              float[4](v.x, v.y, v.z, v.w), a.x);
result = a.y < 0.5 ? vec4(m.mean, m.deviations, m.alpha2) : vec4(m.weight);
"""


def block_inputs(n: int = 6000) -> dict[str, np.ndarray]:
    """Four slopes about a centre in [-20, 20] with a spread of 10^U(-6, 1) (steep but even
    blocks to wild ones), variances in [0, 800] for half the rows and 0 for the others (a
    level-1 block: single texels), a mean alpha^2 in [0, 1]."""
    rng = np.random.default_rng(RNG_SEED + 3)
    centre = rng.uniform(-20.0, 20.0, (n, 1, 2))
    spread = 10.0 ** rng.uniform(-6.0, 1.0, (n, 1, 1))
    s = np.clip(centre + spread * rng.normal(size=(n, 4, 2)), -20.0, 20.0)
    v = rng.uniform(0.0, 800.0, (n, 4)) * (rng.uniform(size=(n, 1)) < 0.5)
    return {
        "s01": f32(s[:, :2].reshape(n, 4)),
        "s23": f32(s[:, 2:].reshape(n, 4)),
        "v": f32(v),
        "a": f32(rng.uniform(0.0, 1.0, n)),
    }


def test_chain_block4_glsl_matches_twin(gl: GLContext) -> None:
    """chain_block4: the mean within 4 U of max |s_i|, deviations within 14 U relative plus
    16 U^2 max |s_i|^2 (docstring: the mean's own error enters only squared), weight 1 and
    alpha^2 exact."""
    x = block_inputs()
    rows = len(x["v"])
    s = np.concatenate([x["s01"].reshape(rows, 2, 2), x["s23"].reshape(rows, 2, 2)], axis=1)
    a = np.column_stack([x["a"], np.zeros(rows)])
    first = run_kernel(gl.ctx, CHAIN, BLOCK_BODY, {**x, "a": a})
    a[:, 1] = 1.0
    second = run_kernel(gl.ctx, CHAIN, BLOCK_BODY, {**x, "a": a})
    m = chain_block4(s, x["v"], x["a"])
    biggest = np.abs(s).max(axis=(1, 2))
    check(gl, "chain_block4 mean", np.abs(first[:, :2] - m.mean).max(-1) / biggest, BLOCK_MEAN_ABS)
    allowed = BLOCK_DEVIATIONS_REL * m.deviations + BLOCK_DEVIATIONS_ABS * biggest**2
    deviations_error = np.abs(first[:, 2] - m.deviations) / allowed
    check(gl, "chain_block4 deviations (of the bound)", deviations_error, 1.0)
    np.testing.assert_array_equal(first[:, 3], m.alpha2)
    np.testing.assert_array_equal(second[:, 0], m.weight)


def test_chain_stored_glsl_matches_twin(gl: GLContext) -> None:
    """chain_stored: the mean exact, variance and alpha^2 (a division each) within 4 U."""
    rng = np.random.default_rng(RNG_SEED + 4)
    n = 4000
    weight = np.where(
        rng.uniform(size=n) < 0.5, rng.integers(1, 4**12, n), rng.uniform(0.01, 1e4, n)
    )
    weight[:3] = [1.0, 3.0, 4**12]
    mean = rng.uniform(-20.0, 20.0, (n, 2))
    a = f32(np.column_stack([weight, mean, weight * rng.uniform(0.0, 800.0, n)]))
    b = f32(weight * rng.uniform(0.0, 1.0, n))
    body = "result = chain_stored(ChainMoments(a.x, a.yz, a.w, b.x));"
    out = run_kernel(gl.ctx, CHAIN, body, {"a": a, "b": b})
    ref = chain_stored(ChainMoments(a[:, 0], a[:, 1:3], a[:, 3], b))
    np.testing.assert_array_equal(out[:, :2], ref[:, :2])
    check(gl, "chain_stored", relative_error(out[:, 2:], ref[:, 2:], 1e-30), STORED_REL)


def test_chain_texel_glsl_matches_twin(gl: GLContext) -> None:
    """chain_texel: the normal within 16 U absolute, r within 3.5 U relative (docstring),
    on slopes up to the floor's 20 and gentle ones, variances negative (rounding), 0, in
    [0, 2] and 800, alpha^2 0, 1 and between."""
    rng = np.random.default_rng(RNG_SEED + 5)
    n = 6000
    slopes = np.where(
        rng.uniform(size=(n, 1)) < 0.3, rng.uniform(-20.0, 20.0, (n, 2)), rng.normal(0, 0.1, (n, 2))
    )
    variance = rng.uniform(0.0, 2.0, n)
    variance[::7], variance[1::7], variance[2::7] = -1e-6, 0.0, 800.0
    alpha2 = rng.uniform(0.0, 1.0, n)
    alpha2[3::11], alpha2[4::11] = 0.0, 1.0
    alpha2[1::7] = 0.0  # with no variance: r = 0
    stored = f32(np.column_stack([slopes, variance, alpha2]))
    out = run_kernel(gl.ctx, CHAIN, "result = chain_texel(m);", {"m": stored})
    ref = chain_texel(stored)
    assert (ref[:, 3] == 0.0).sum() > 100 and (ref[:, 3] == 1.0).sum() > 1000
    check(gl, "chain_texel normal", np.abs(out[:, :3] - ref[:, :3]), TEXEL_NORMAL_ABS)
    check(gl, "chain_texel r", relative_error(out[:, 3], ref[:, 3], 1e-30), TEXEL_R_REL)


# --- the twins against what they stand for -------------------------------------------------


def test_block4_is_four_merges_of_equal_weight() -> None:
    """chain_block4's moments as stored are chain_merge's of the same four parts, weight
    one each, from chain_empty (Chan et al.'s update, two ways), to float64 rounding."""
    x = block_inputs(2000)
    rows = len(x["v"])
    s = np.concatenate([x["s01"].reshape(rows, 2, 2), x["s23"].reshape(rows, 2, 2)], axis=1)
    a2 = np.random.default_rng(RNG_SEED + 6).uniform(0.0, 1.0, (rows, 4))
    m = chain_empty((rows,))
    for i in range(4):
        m = chain_merge(m, 1.0, s[:, i], x["v"][:, i], a2[:, i])
    merged = chain_stored(m)
    block = chain_stored(chain_block4(s, x["v"], a2.mean(axis=-1)))
    np.testing.assert_allclose(block, merged, rtol=1e-12, atol=1e-12)


def twin_chain(rgb: np.ndarray, green: np.ndarray, scale: float, factor: float) -> list:
    """The chain as normal_chain.frag composes the twins: level 0 ``chain_normal`` and the
    roughness; each later level from the stored moments of the one before (level 0's: each
    texel's slope, no variance, r^4), ``chain_block4`` where a texel is short of the last
    row and column, else ``chain_merge`` of every child under it (``footprint_last_child``)
    weighed by its level-0 texels (``footprint_texels``); ``chain_texel`` of what it stores.
    (h_k, w_k, 4) float64 levels."""
    h, w = rgb.shape[:2]
    n = chain_normal(rgb / 255.0, scale)
    r = factor * (green / 255.0)
    levels = [np.concatenate([n, r[..., None]], axis=-1)]
    stored = np.concatenate([chain_slope(n), np.zeros((h, w, 1)), (r * r * r * r)[..., None]], -1)
    for k in range(1, max(h, w).bit_length()):
        child = stored
        hc, wc = child.shape[:2]
        size_y, size_x = max(1, h >> k), max(1, w >> k)
        y, x = np.arange(size_y)[:, None], np.arange(size_x)[None, :]
        first_y, first_x = np.minimum(2 * y, hc - 1), np.minimum(2 * x, wc - 1)
        last_y = footprint_last_child(y, hc, size_y)
        last_x = footprint_last_child(x, wc, size_x)
        m = chain_empty((size_y, size_x))
        for dy in range(3):
            for dx in range(3):
                cy, cx = first_y + dy, first_x + dx
                inside = (cy <= last_y) & (cx <= last_x)
                cy, cx = np.minimum(cy, hc - 1), np.minimum(cx, wc - 1)
                weight = footprint_texels(cy, k - 1, hc, h) * footprint_texels(cx, k - 1, wc, w)
                c = child[cy, cx]
                m = chain_merge(m, np.where(inside, weight, 0.0), c[..., :2], c[..., 2], c[..., 3])
        block = [child[np.minimum(first_y + i // 2, hc - 1), np.minimum(first_x + i % 2, wc - 1)]
                 for i in range(4)]  # fmt: skip
        b = np.stack(block, axis=-2)
        quad = chain_block4(b[..., :2], b[..., 2], 0.25 * b[..., 3].sum(axis=-1))
        interior = (y < size_y - 1) & (x < size_x - 1)
        stored = np.where(interior[..., None], chain_stored(quad), chain_stored(m))
        levels.append(chain_texel(stored))
    return levels


def cpu_chain(
    rgb: np.ndarray, green: np.ndarray, scale: float, factor: float
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """app/textures/mips.py's ``variance`` chain of the same map, decoded as
    app/textures/maps.py decodes a glTF material's (``decode_normal_map``, then the normal
    scale on n.xy, normalised): (the float64 levels 1 .. of its moment sums, footprint
    means of each texel's ``_moment``s through ``_filtered``; the float32 levels 0 .. that
    ``chain_levels`` makes of them)."""
    n = decode_normal_map(rgb.astype(np.uint8))
    if scale != 1.0:
        n[..., :2] *= scale
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
    r = factor * (green / 255.0)
    names = ("sx", "sy", "sxx", "syy", "a2")
    sums = np.stack([_moment(name, n, r) for name in names], axis=-1)
    counts_y, counts_x = np.ones(n.shape[0]), np.ones(n.shape[1])
    exact = []
    while max(counts_y.size, counts_x.size) > 1:
        sums = _halve(sums)
        counts_y, counts_x = _halve_counts(counts_y), _halve_counts(counts_x)
        means = sums / (counts_y[:, None, None] * counts_x[None, :, None])
        normal, rough = _filtered("variance", {k: means[..., c] for c, k in enumerate(names)})
        exact.append(np.concatenate([normal, rough[..., None]], axis=-1))
    made = chain_levels(lambda y0, y1: (n[y0:y1], r[y0:y1]), n.shape[:2], "variance")
    return exact, made


CHAIN_CASES = [
    ((37, 29), 1.0, 0.9, False),
    ((37, 29), 1.7, 0.4, False),  # a normal scale
    ((16, 16), 0.6, 1.0, False),
    ((1, 9), 1.0, 1.0, False),  # sides of one texel
    ((33, 1), 1.0, 0.5, False),
    ((5, 3), 1.0, 0.7, False),
    ((24, 40), 1.0, 0.3, True),  # normals down to the surface and below it: the floor
]


@pytest.mark.parametrize(("shape", "scale", "factor", "steep"), CHAIN_CASES)
def test_twins_compose_to_the_cpu_chain(
    shape: tuple[int, int], scale: float, factor: float, steep: bool
) -> None:
    """The twins composed over the footprints (``twin_chain``) are mips.py's float64
    ``variance`` chain, every level within 1e-13 (measured 1.4e-15 at most: one box filter
    of the slope moments, merged pairwise or summed), and the float32 levels
    ``chain_levels`` makes within their rounding, U |value|, plus as much. The maps' slopes
    are gentle (|s| <= 0.3) unless ``steep``, so that alpha'^2 stays below 1 and r tells."""
    rng = np.random.default_rng(sum(shape) + int(10 * scale))
    rgb = rng.integers(100, 157, (*shape, 3))
    rgb[..., 2] = rng.integers(220, 256, shape)
    if steep:
        rgb = rng.integers(0, 256, (*shape, 3))
    green = rng.integers(0, 256, shape).astype(np.float64)
    ours = twin_chain(rgb, green, scale, factor)
    exact, made = cpu_chain(rgb, green, scale, factor)
    assert len(ours) == len(made) == len(exact) + 1 == max(shape).bit_length()
    worst = 0.0
    for k, (a, b) in enumerate(zip(ours, made, strict=True)):
        assert a.shape == b.shape, k
        if k > 0:
            worst = max(worst, float(np.abs(a - exact[k - 1]).max()))
            assert np.all(np.abs(a - exact[k - 1]) <= CHAIN_LEVELS_ABS), k
        cpu = b.astype(np.float64)
        assert np.all(np.abs(a - cpu) <= U * np.abs(cpu) + CHAIN_LEVELS_ABS), k
    if not steep:  # r informative: below the saturation of alpha'^2
        assert all(np.all(level[..., 3] < 1.0) for level in ours[1:])
    else:  # the n.z floor at work
        assert np.any(ours[0][..., 2] == CHAIN_MIN_NORMAL_Z)
    print(f"{shape} scale {scale}: largest float64 difference {worst:.2e}")
