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
"""

from __future__ import annotations

import numpy as np

from app.reference.tonemap import post_process

RELATIVE_FLOOR = 1e-3  # of the peak: below it the error is measured absolutely


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
    peak = float(np.abs(want).max())
    floor = max(RELATIVE_FLOOR * peak, np.finfo(np.float64).tiny)
    max_rel = float((np.abs(diff) / np.maximum(np.abs(want), floor)).max())
    flip_mean = None
    if flip:
        import flip_evaluator

        # Clipped to the display's [0, 1], which the 8-bit post pass does too.
        test = np.clip(post_process(np.asarray(hdr, np.float64), exposure_ev, tonemap), 0, 1)
        reference = np.clip(post_process(np.asarray(ref, np.float64), exposure_ev, tonemap), 0, 1)
        _, mean, _ = flip_evaluator.evaluate(
            np.ascontiguousarray(reference, np.float32),
            np.ascontiguousarray(test, np.float32),
            "LDR",
            applyMagma=False,
        )
        flip_mean = float(mean)
    return {"rel_rmse": rel_rmse, "max_rel_err": max_rel, "flip_mean": flip_mean}
