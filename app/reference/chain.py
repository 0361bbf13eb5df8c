"""Twin of glsl/material/chain.glsl: the per-texel steps of the normal/roughness mip chain
the GL draws (RTR4 §9.13, "Blending and Filtering Materials"), name for name, in float64.

A mip texel of a normal map should stand for the spread of the normals under it, not only
for their average: the spread is what makes a bumpy surface look rough from afar. The
chain keeps, for each texel's footprint, the moments that LEAN mapping (Olano & Baker
2010) works with: the mean slope s = -n.xy / n.z, the total variance of the slopes
Var(s.x) + Var(s.y), and the mean alpha^2 = r^4 of the material's own lobes. A texel is
turned back into a normal (that of the mean slope) and a roughness alpha'^2 = min(1,
alpha^2 + 2 sigma^2), sigma^2 the variance per axis (a Beckmann lobe of roughness alpha
has a slope variance of alpha^2 / 2 per axis, and variances of independent slopes add).

Footprints are merged from their parts' means and variances with the pairwise update of
Chan, Golub & LeVeque (1979): the variance of a union is the weighted mean of the parts'
variances plus the spread of their means about the union's mean. The GLSL does this in
float32, where forming E[s^2] - E[s]^2 from two sums would cancel away the small variance
of a steep, even footprint; here the same update runs in float64.

The functions mirror the GLSL ones (``chain_normal``, ``chain_slope``, ``chain_empty``,
``chain_merge``, ``chain_block4``, ``chain_stored``, ``chain_texel``) and broadcast over
leading axes; ``ChainMoments`` is the GLSL struct as a dataclass of arrays. The float64
chain of app/textures/mips.py (``variance``) is the same box filter computed from sums of
moments; tests/test_chain_glsl.py composes these twins over the footprints of
app/reference/footprint.py and holds them to it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# The smallest tangent-space n.z a chain lets a normal have (glsl/material/chain.glsl
# CHAIN_MIN_NORMAL_Z; app/textures/mips.py takes its MIN_NORMAL_Z from here). A normal with
# n.z <= 0 faces into the surface, and the slope -n.xy / n.z grows without bound as n.z
# -> 0, so a single grazing texel would swamp a footprint's variance; 0.05 (87.1 degrees
# from the surface normal) caps |slope| at 20.
CHAIN_MIN_NORMAL_Z = 0.05


def _f64(x: np.ndarray | float) -> np.ndarray:
    return np.asarray(x, np.float64)


def _norm(v: np.ndarray) -> np.ndarray:
    """|v| over the last axis."""
    return np.sqrt(np.sum(v * v, axis=-1))


def chain_normal(unorm: np.ndarray, scale: np.ndarray | float) -> np.ndarray:
    """A glTF normal-map texel as a unit tangent-space normal (..., 3).

    ``unorm`` (..., 3): the texel as the GL samples a UNORM texture, each channel v / 255.
    Decoded as unorm * 2 - 1 and normalised (no 8-bit channel decodes to 0, so the vector
    has a length); where n.z < CHAIN_MIN_NORMAL_Z, n.z is raised to the floor and n.xy
    rescaled to keep unit length (app/textures/mips.py ``decode_normal_map``); then, where
    ``scale`` (...) is not 1, the material's normal scale multiplies n.xy and the normal is
    normalised again (glTF's ``normalTexture.scale``). Scale 1 leaves the normal untouched,
    as the GLSL's branch does."""
    v = _f64(unorm) * 2.0 - 1.0
    n = v / _norm(v)[..., None]
    low = n[..., 2] < CHAIN_MIN_NORMAL_Z
    xy_length = _norm(n[..., :2])
    # Below the floor |n.xy| >= sqrt(1 - 0.05^2); elsewhere the ratio is not used.
    rescale = np.sqrt(1.0 - CHAIN_MIN_NORMAL_Z**2) / np.where(low, xy_length, 1.0)
    n = np.where(
        low[..., None],
        np.concatenate(
            [n[..., :2] * rescale[..., None], np.full_like(n[..., 2:], CHAIN_MIN_NORMAL_Z)],
            axis=-1,
        ),
        n,
    )
    s = np.broadcast_to(_f64(scale), n.shape[:-1])
    scaled = np.concatenate([n[..., :2] * s[..., None], n[..., 2:]], axis=-1)
    scaled = scaled / _norm(scaled)[..., None]
    return np.where((s != 1.0)[..., None], scaled, n)


def chain_slope(n: np.ndarray) -> np.ndarray:
    """The slope (..., 2) of a unit normal n (..., 3): -n.xy / n.z with n.z floored to
    CHAIN_MIN_NORMAL_Z, so that |slope| <= 20 for any unit normal."""
    n = _f64(n)
    return -n[..., :2] / np.maximum(n[..., 2], CHAIN_MIN_NORMAL_Z)[..., None]


@dataclass
class ChainMoments:
    """A running merge of weighted footprints (the GLSL struct of the same name), arrays
    broadcasting over texels."""

    weight: np.ndarray  # (...) the weight merged so far (level-0 texels in a chain)
    mean: np.ndarray  # (..., 2) the weighted mean slope
    deviations: np.ndarray  # (...) the weighted sum of squared deviations, both axes
    alpha2: np.ndarray  # (...) the weighted sum of alpha^2


def chain_empty(shape: tuple[int, ...] = ()) -> ChainMoments:
    """Nothing merged yet: weight, mean, deviations and alpha^2 all 0, one per element of
    ``shape`` (the GLSL's takes no argument: one texel)."""
    return ChainMoments(np.zeros(shape), np.zeros((*shape, 2)), np.zeros(shape), np.zeros(shape))


def chain_merge(
    m: ChainMoments,
    w: np.ndarray | float,
    s: np.ndarray,
    v: np.ndarray | float,
    a2: np.ndarray | float,
) -> ChainMoments:
    """Chan, Golub & LeVeque 1979, the pairwise update: ``m`` merged with a part of weight
    ``w``, mean slope ``s`` (..., 2), total slope variance ``v`` and mean alpha^2 ``a2``.

    With d = s - mean: mean' = mean + d w / (W + w), deviations' = deviations + v w +
    |d|^2 W w / (W + w) (the part's own deviations and those of the two means about the
    merged one), alpha^2 sums weighted. A new ChainMoments; ``m`` is left as it was."""
    w = _f64(w)
    total = m.weight + w
    d = _f64(s) - m.mean
    mean = m.mean + d * (w / total)[..., None]
    deviations = m.deviations + _f64(v) * w + np.sum(d * d, axis=-1) * (m.weight * w / total)
    alpha2 = m.alpha2 + _f64(a2) * w
    return ChainMoments(total, mean, deviations, alpha2)


def chain_block4(s: np.ndarray, v: np.ndarray, a2: np.ndarray | float) -> ChainMoments:
    """Four parts of equal weight at once (a 2x2 block of one level's texels): mean slopes
    ``s`` (..., 4, 2), total slope variances ``v`` (..., 4), and their mean alpha^2 ``a2``.

    The mean of the four means, and as deviations the mean of the variances plus the
    spread of the means about their mean (Chan et al.'s update for equal weights, in two
    passes); weight 1, so that ``chain_stored`` reads it as it reads a running merge."""
    s = _f64(s)
    mean = 0.25 * ((s[..., 0, :] + s[..., 1, :]) + (s[..., 2, :] + s[..., 3, :]))
    d = s - mean[..., None, :]
    spread = np.sum(_f64(v) + np.sum(d * d, axis=-1), axis=-1)
    a2 = np.broadcast_to(_f64(a2), spread.shape)
    return ChainMoments(np.ones_like(spread), mean, 0.25 * spread, a2)


def chain_stored(m: ChainMoments) -> np.ndarray:
    """The moments as a level stores them (..., 4): mean s.x, mean s.y, the total slope
    variance (deviations / weight) and the mean alpha^2 (alpha^2 / weight)."""
    return np.concatenate(
        [m.mean, (m.deviations / m.weight)[..., None], (m.alpha2 / m.weight)[..., None]],
        axis=-1,
    )


def chain_texel(stored: np.ndarray) -> np.ndarray:
    """A level's texel (..., 4) from its stored moments: the unit normal of the mean slope,
    (-s.x, -s.y, 1) normalised, and the perceptual roughness alpha'^(1/2) of alpha'^2 =
    min(1, alpha^2 + 2 sigma^2) with sigma^2 = (Var(s.x) + Var(s.y)) / 2, i.e. alpha^2 plus
    the total variance (app/reference/filtering.py ``alpha2_from_slope_variance``); a
    negative variance (rounding) counts as 0."""
    stored = _f64(stored)
    alpha2 = np.minimum(1.0, stored[..., 3] + np.maximum(stored[..., 2], 0.0))
    v = np.concatenate([-stored[..., :2], np.ones_like(stored[..., 2:3])], axis=-1)
    normal = v / _norm(v)[..., None]
    return np.concatenate([normal, np.sqrt(np.sqrt(alpha2))[..., None]], axis=-1)
