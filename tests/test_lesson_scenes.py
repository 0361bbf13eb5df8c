"""The lesson's scenes show what the walkthrough says they show (RTR4 chapter 9), rendered
with the real shaders at a small size."""

from __future__ import annotations

import numpy as np

from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.conftest import REPO
from tests.test_reference_agreement import interior


def test_the_white_lambert_sphere_vanishes_in_the_furnace(gl_egl) -> None:
    """RTR4 §9.3: a white Lambertian sphere reflects exactly the furnace's radiance 1, the
    grey one 0.5, to the pixel's rim: no specular lobe is left on them (Schlick's F with
    F0 = 0 would add (1 - h.l)^5 and a rim of up to 1.055 here)."""
    r = Renderer(gl_egl, load_scene(REPO / "scenes" / "sec3_furnace.toml"), (320, 120))
    try:
        r.render()
        hdr = r.read_hdr()[..., :3].astype(np.float64)
        g = r.read_gbuffer()
    finally:
        r.release()
    covered = interior(g.depth > 0.0)
    # the two leftmost spheres, materials 0 and 1 of the scene
    for material, radiance in ((0, 1.0), (1, 0.5)):
        sel = covered & (g.material_id == material)
        assert sel.sum() > 500
        err = np.abs(hdr[sel] - radiance).max()
        assert err <= 1e-3, f"material {material}: off the furnace by {err:.4f}"
