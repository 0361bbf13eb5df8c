"""Image error against the float64 reference: the three numbers of each bench row.

All three compare a GPU HDR image with the float64 twin's image of the same G-buffer
(app/bench/pairs.py, reference_hdr), over the pixels a surface covers (the background is
copied, not computed):

* ``rel_rmse``: the RMS of the error over the RMS of the reference, all channels
  together, a scale-free "how wrong is the image" that large bright areas dominate;
* ``max_rel_err``: the largest |gpu - ref| / max(|ref|, 1e-3 peak) over pixels and
  channels, as tests/test_reference_agreement.py measures it: relative where the
  reference is not tiny, so a dark pixel's noise cannot dominate;
* ``flip_mean``: the mean of NVIDIA's FLIP (LDR) between the two images after the scene's
  exposure and tone map (app.reference.tonemap.post_process, in float64 for both), i.e.
  how visible the difference is on a display; 0 is identical, 1 the largest difference.

``interior_errors`` measures the whole pipeline instead, against the float64 ray-caster
(app/reference/raycast.py): the median, 99th percentile and largest relative
error and the mean FLIP over the pixels away from silhouettes.
"""

from __future__ import annotations

import numpy as np

from app.reference.tonemap import post_process

RELATIVE_FLOOR = 1e-3  # of the peak: below it the error is measured absolutely


def flip_map(
    hdr: np.ndarray, ref: np.ndarray, exposure_ev: float, tonemap: str
) -> tuple[np.ndarray, float]:
    """NVIDIA's FLIP (LDR) between ``hdr`` and ``ref`` after the scene's exposure and tone
    map (app.reference.tonemap.post_process in float64 for both), clipped to the
    display's [0, 1] as the 8-bit post pass clips: per pixel, (H, W) float64, and the
    evaluator's own mean over the image."""
    import flip_evaluator

    test = np.clip(post_process(np.asarray(hdr, np.float64), exposure_ev, tonemap), 0, 1)
    reference = np.clip(post_process(np.asarray(ref, np.float64), exposure_ev, tonemap), 0, 1)
    error_map, mean, _ = flip_evaluator.evaluate(
        np.ascontiguousarray(reference, np.float32),
        np.ascontiguousarray(test, np.float32),
        "LDR",
        applyMagma=False,
    )
    return np.asarray(error_map, np.float64).reshape(np.shape(hdr)[:2]), float(mean)


def image_errors(
    hdr: np.ndarray,
    ref: np.ndarray,
    covered: np.ndarray,
    exposure_ev: float,
    tonemap: str,
    flip: bool = True,
) -> dict[str, float | None]:
    """``rel_rmse``, ``max_rel_err`` and ``flip_mean`` of ``hdr`` against ``ref``."""
    gpu = np.asarray(hdr, np.float64)[covered]
    want = np.asarray(ref, np.float64)[covered]
    if want.size == 0:
        return {"rel_rmse": None, "max_rel_err": None, "flip_mean": None}
    diff = gpu - want
    norm = float(np.sqrt(np.mean(want * want)))
    rel_rmse = float(np.sqrt(np.mean(diff * diff))) / norm if norm > 0.0 else None
    max_rel = float(relative_errors(hdr, ref, covered).max())
    flip_mean = flip_map(hdr, ref, exposure_ev, tonemap)[1] if flip else None
    return {"rel_rmse": rel_rmse, "max_rel_err": max_rel, "flip_mean": flip_mean}


def relative_errors(hdr: np.ndarray, ref: np.ndarray, sel: np.ndarray) -> np.ndarray:
    """|hdr - ref| / max(|ref|, RELATIVE_FLOOR * peak) per channel of the pixels ``sel``
    picks (flattened), the peak being the largest |ref| there: relative where the
    reference is not tiny, absolute below a thousandth of the brightest value."""
    want = np.asarray(ref, np.float64)[sel]
    got = np.asarray(hdr, np.float64)[sel]
    peak = float(np.abs(want).max())
    floor = max(RELATIVE_FLOOR * peak, np.finfo(np.float64).tiny)
    return (np.abs(got - want) / np.maximum(np.abs(want), floor)).ravel()


def interior_errors(
    hdr: np.ndarray,
    ref: np.ndarray,
    interior: np.ndarray,
    exposure_ev: float,
    tonemap: str,
    flip: bool = True,
) -> dict[str, float | None]:
    """The error of ``hdr`` against a ray-cast reference over the ``interior`` pixels
    (app/reference/raycast.py interior_mask: away from silhouettes, where coverage and not
    shading decides): the median, 99th percentile and largest ``relative_errors`` over
    those pixels and their channels, and the mean FLIP of those pixels after the scene's
    exposure and tone map (as ``image_errors`` computes it, averaged over the interior
    only). The accuracy targets: median <= 1e-5, p99 <= 1e-4, mean FLIP <= 1e-3."""
    if not np.any(interior):
        return {"median": None, "p99": None, "max": None, "flip_mean": None}
    rel = relative_errors(hdr, ref, interior)
    flip_mean = None
    if flip:
        flip_mean = float(flip_map(hdr, ref, exposure_ev, tonemap)[0][interior].mean())
    return {
        "median": float(np.median(rel)),
        "p99": float(np.percentile(rel, 99.0)),
        "max": float(rel.max()),
        "flip_mean": flip_mean,
    }
