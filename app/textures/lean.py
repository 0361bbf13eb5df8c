"""Mip chains of a normal map's slope moments, so that filtering keeps the *direction* of the
normals' spread (RTR4 §9.13; Olano & Baker 2010, "LEAN Mapping").

The isotropic ``variance`` chain (app/textures/mips.py) folds the spread of the normals a
texel averages into one roughness: a groove map, whose normals tilt only across the
grooves, becomes a grey isotropic roughness at a distance, where the supersampled surface
keeps a highlight stretched across the grooves (brushed metal). ``render.normal_filter =
"lean"`` keeps the spread as a 2x2 covariance instead. Per texel of level k, from the
tangent-space slopes s = (-n.x/n.z, -n.y/n.z) of the source texels in its footprint:

* B = E[s] and M = E[s s^T], exact box means over the footprint (``mips.box_levels``: every
  source texel weighs the same, at every level), so Sigma = M - B B^T is the footprint's
  slope covariance, anisotropic (app/reference/filtering.py ``slope_covariance``);
* the normal/roughness chain (RGBA: xyz the normal of the mean slope B, a the material's
  own perceptual roughness E[alpha^2]^(1/4), no spread added) and a second chain, RGB:
  Sigma_xx, Sigma_yy, Sigma_xy (the ``slope_covariance`` map; all 0 at level 0, a single
  texel's slope has no spread).

The G-buffer pass adds Sigma to the material's lobe and turns the sum into anisotropic
roughness and a tangent direction (glsl/material/filtering.glsl
``lean_anisotropic_roughness``). Storing the central Sigma rather than M keeps float16
storage free of the cancellation M - B B^T would suffer at a texel whose slope is large
and spread small; trilinear filtering then averages covariances and leaves out the spread
of B between the 2x2 texels it mixes (the level already holds the spread within them).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from app.common.models import MaterialParams
from app.reference.filtering import (
    SPREAD_FOOTPRINT,
    SPREAD_FOOTPRINTS,
    directional_spread,
    slope_covariance,
    spread_sample_origins,
)
from app.textures.mips import (
    MIN_NORMAL_Z,
    BandSource,
    box_levels,
    decode_normal_map,
    float16_rows_up,
)

# The material option and render.normal_filter value that selects these chains.
LEAN = "lean"
# The render.normal_filter value (the default) that picks LEAN for a normal map whose spread
# keeps a direction and the isotropic variance chain for any other (``auto_filter``).
AUTO = "auto"


def _slopes(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent-space slopes of unit normals, n.z floored to MIN_NORMAL_Z as the variance
    chain floors it (app/textures/mips.py)."""
    nz = np.maximum(n[..., 2], MIN_NORMAL_Z)
    return -n[..., 0] / nz, -n[..., 1] / nz


def lean_chain_levels(
    source: BandSource, shape: tuple[int, int], rows_up_float16: bool = False
) -> list[np.ndarray]:
    """The normal/roughness chain of the ``lean`` filter, (h_k, w_k, 4) float32 levels down
    to 1x1 (GL sizes; ``rows_up_float16`` as mips.chain_levels): level 0 the source, level
    k the normal of the footprint's mean slope and E[alpha^2]^(1/4), the material's own
    roughness alone (the spread travels in ``covariance_levels``)."""
    h, w = shape
    level0 = np.empty((h, w, 4), np.float32)

    def moments(y0: int, y1: int) -> np.ndarray:
        n, r = source(y0, y1)
        level0[y0:y1, :, :3] = n  # each band its own rows (mips.each_band)
        level0[y0:y1, :, 3] = r
        sx, sy = _slopes(n)
        return np.stack([sx, sy, r**4], axis=-1)

    means = box_levels(moments, (h, w, 3))
    levels = [level0]
    for level in means[1:]:
        m = level.astype(np.float64)
        normal = np.stack([-m[..., 0], -m[..., 1], np.ones_like(m[..., 0])], axis=-1)
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        out = np.empty((*m.shape[:2], 4), np.float32)
        out[..., :3] = normal
        out[..., 3] = np.maximum(m[..., 2], 0.0) ** 0.25
        levels.append(out)
    return [float16_rows_up(lv) for lv in levels] if rows_up_float16 else levels


def covariance_levels(
    normals: BandSource | np.ndarray, shape: tuple[int, int], rows_up_float16: bool = False
) -> list[np.ndarray]:
    """The ``slope_covariance`` chain: (h_k, w_k, 3) float32 levels down to 1x1 (GL sizes),
    Sigma_xx, Sigma_yy, Sigma_xy of each texel's footprint (level 0: zeros). ``normals``:
    (H, W, 3) unit tangent-space normals, or a source of bands as mips.chain_levels reads
    (its roughness unused)."""
    h, w = shape
    if isinstance(normals, np.ndarray):
        array = normals
        normals = lambda y0, y1: (array[y0:y1], None)  # noqa: E731

    def moments(y0: int, y1: int) -> np.ndarray:
        sx, sy = _slopes(normals(y0, y1)[0])
        return np.stack([sx, sy, sx * sx, sy * sy, sx * sy], axis=-1)

    means = box_levels(moments, (h, w, 5))
    levels = [np.zeros((h, w, 3), np.float32)]
    levels += [slope_covariance(m.astype(np.float64)).astype(np.float32) for m in means[1:]]
    return [float16_rows_up(lv) for lv in levels] if rows_up_float16 else levels


def sampled_spread(
    normals: np.ndarray, scale: float = 1.0, footprint: int = SPREAD_FOOTPRINT
) -> np.ndarray:
    """The mean footprint covariance of a normal map (app/reference/filtering.py
    ``mean_footprint_covariance``, its float64 twin) from the sampled footprints' texels
    alone: ``normals`` (H, W, 3) unit normals, or an 8-bit normal map (H, W, 3|4) uint8
    decoded as ``maps.decode_normals`` decodes it with ``scale`` (only the sampled texels,
    at most 512^2: the choice costs a fraction of the chain it chooses, docs/filtering.md).
    Returns (3,) Sigma_xx, Sigma_yy, Sigma_xy."""
    xs, fx = spread_sample_origins(normals.shape[1], footprint)
    ys, fy = spread_sample_origins(normals.shape[0], footprint)
    rows = (ys[:, None] + np.arange(fy)).ravel()
    cols = (xs[:, None] + np.arange(fx)).ravel()
    texels = normals[np.ix_(rows, cols)]  # a gather: take would copy a strided view whole
    if texels.dtype == np.uint8:
        texels = decode_normal_map(texels)
        if scale != 1.0:
            texels[..., :2] *= scale
            texels /= np.linalg.norm(texels, axis=-1, keepdims=True)
    sx, sy = _slopes(np.asarray(texels, np.float64))
    # Every footprint holds as many texels, so the mean over footprints of M - B B^T is
    # E[s s^T] over every sampled texel less the footprints' mean B B^T: the second moments
    # summed once, not per footprint (the twin's per-footprint form, to rounding).
    shape = (len(ys), fy, len(xs), fx)
    bx, by = (a.reshape(shape).mean(axis=(1, 3)) for a in (sx, sy))
    return np.array(
        [
            (sx * sx).mean() - (bx * bx).mean(),
            (sy * sy).mean() - (by * by).mean(),
            (sx * sy).mean() - (bx * by).mean(),
        ]
    )


def spread_levels(normals: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """``sampled_spread`` at each footprint size of SPREAD_FOOTPRINTS in turn, stopping
    after the first that is not directional: (k, 3), what ``directional_spread`` judges."""
    covariances = []
    for footprint in SPREAD_FOOTPRINTS:
        covariances.append(sampled_spread(normals, scale, footprint))
        if not directional_spread(covariances[-1]):
            break
    return np.array(covariances)


def auto_filter(normals: np.ndarray, scale: float = 1.0) -> str:
    """What ``render.normal_filter = "auto"`` builds for a normal map (``sampled_spread``'s
    arguments): ``lean`` where its slopes spread along one direction (brushed or grooved
    metal, app/reference/filtering.py ``directional_spread``), else ``variance``, which
    costs LEAN's second map, its chain's time and the anisotropic lighting only where they
    keep a highlight's direction."""
    return LEAN if directional_spread(spread_levels(normals, scale)) else "variance"


def lean_defines(layers: Sequence[tuple[MaterialParams, Mapping[str, object]]]) -> dict[str, int]:
    """The G-buffer program's define for LEAN's spread factor (glsl/material/filtering.glsl
    LEAN_SPREAD), from a part's (params, maps) layers: ``LEAN_GGX`` where the first layer
    with a ``slope_covariance`` map shades GGX (its covariance widens the lobe by
    GGX_LEAN_SPREAD, app/reference/filtering.py ``ggx_lean_spread``); nothing otherwise,
    so a Beckmann material's program is the one it was (variance matching, k = 1). A
    blend whose layers differ in NDF takes that layer's for both."""
    for params, maps in layers:
        if "slope_covariance" in maps:
            return {"LEAN_GGX": 1} if params.model.ndf == "ggx" else {}
    return {}


def lean_params(params: MaterialParams) -> MaterialParams:
    """A material whose normal map carries a covariance map: its model anisotropic, so that
    the G-buffer keeps a tangent and an anisotropy per pixel and the lighting pass shades
    the anisotropic lobe (RTR4 §9.8) the covariance becomes; its numbers unchanged."""
    return replace(params, model=replace(params.model, anisotropic=True))
