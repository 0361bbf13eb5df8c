"""RTR4 §9.6: the distribution of visible normals changes with the view angle
(app/brdf/vndf.py, the figure of docs/microfacet.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from app.brdf import vndf


@pytest.mark.parametrize("ndf", list(vndf.NDFS))
def test_visible_normals_integrate_to_one_and_turn_towards_the_viewer(ndf: str) -> None:
    """For every view angle D_v integrates to 1 over the normals (measured 0.999999 for
    GGX, whose long tail the midpoint rule truncates, 1.000000 for Beckmann), its
    peak in the plane of incidence moves towards the viewer as theta_v grows, and normals
    facing away from the viewer (v.m <= 0) are not visible."""
    theta_m = np.linspace(-math.pi / 2, math.pi / 2, 1801)
    peaks = []
    for t in (0.0, 30.0, 60.0, 80.0):
        tv = math.radians(t)
        assert vndf.total(ndf, tv, 0.5) == pytest.approx(1.0, abs=1e-4)
        dv = vndf.D_visible(ndf, vndf.in_plane(theta_m), tv, 0.5)
        peaks.append(theta_m[np.argmax(dv)])
        hidden = theta_m < tv - math.pi / 2 - 1e-9  # (the boundary itself rounds)
        assert np.all(dv[hidden] == 0.0)
    assert peaks[0] == pytest.approx(0.0, abs=1e-3)
    assert np.all(np.diff(peaks) > 0.0)


def test_the_figure_is_written(tmp_path) -> None:
    out = tmp_path / "vndf.png"
    assert vndf.main(["-o", str(out)]) == 0
    image = np.asarray(Image.open(out).convert("L"), np.float64)
    assert image.shape[1] > 600 and image.std() > 10.0
