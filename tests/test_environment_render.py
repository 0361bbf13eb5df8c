"""Image environments through the renderer (real GL) against the float64 ray-caster: the
background pass (``[environment] background = true``) and a sphere lit by the split sum
against the ray-caster's cell lights; a scene without the key builds no background pass."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.frame.raycast import reference_scene
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import load_scene

SIZE = (96, 54)


def write_scene(tmp_path: Path, background: bool, source: str = "sky") -> Path:
    # The sky turned 180 degrees puts the map's seam (u = 0 = 1) in the view's centre;
    # the studio turned 150 degrees, so that its key
    # box (STUDIO_BOXES[0]) stands at the top left of the view.
    extra = "sun_direction = [0.3, 0.5, -0.8]\nturbidity = 4.0\nrotation = 180.0\n"
    if source == "studio":
        extra = "rotation = 150.0\n"
    if source == "image":  # a ramp in u: the seam, turned into the view, jumps 0 -> 8
        import OpenEXR

        ramp = np.linspace(0.0, 8.0, 64, dtype=np.float32)[None, :, None]
        rgb = np.ascontiguousarray(np.broadcast_to(ramp, (32, 64, 3)))
        with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": rgb}) as f:
            f.write(str(tmp_path / "ramp.exr"))
        extra = 'file = "ramp.exr"\nrotation = 180.0\n'
    path = tmp_path / "s.toml"
    path.write_text(
        f"""background = [0.0, 0.0, 0.0]
[environment]
source = "{source}"
{extra}intensity = 0.2
samples = 64
background = {str(background).lower()}
[render]
width = {SIZE[0]}
height = {SIZE[1]}
[camera]
position = [0.0, 0.8, 4.0]
target = [0.0, 1.0, 0.0]
fov_y = 45.0
[materials.m]
base_color = [0.7, 0.7, 0.7]
metallic = 0.0
roughness = 1.0
[[objects]]
shape = "sphere"
radius = 0.8
material = "m"
"""
    )
    return path


@pytest.mark.parametrize("source", ["sky", "studio", "image"])
def test_background_and_lit_sphere_match_the_ray_caster(
    gl_egl: GLContext, tmp_path: Path, source: str
) -> None:
    loaded = load_scene(write_scene(tmp_path, True, source))
    renderer = Renderer(gl_egl, loaded)
    try:
        renderer.render()
        hdr = renderer.read_hdr().astype(np.float64)
    finally:
        renderer.release()
    ref = reference_scene(loaded)
    empty = ~ref.covered
    # Background: the bilinear lookup, float32 on the GPU against float64. llvmpipe
    # filters with 8-bit sub-texel weights, so a texel step of D can be missed by D / 256:
    # the error scales with the map's peak, not with each pixel (bound: 2 such steps).
    peak = ref.hdr[empty].max()
    assert empty.sum() > 1000 and np.ptp(ref.hdr[empty][:, 0]) > 0.1 * peak  # not flat
    err = np.abs(hdr[empty] - ref.hdr[empty]) / peak
    print("background error / peak: p99", np.quantile(err, 0.99), "max", err.max())
    assert err.max() < 2.0 / 256.0, err.max()  # measured 3.6e-3 (studio), 2e-4 (sky)
    # The sphere: the renderer's split sum (for a rough grey dielectric, mostly the SH9
    # irradiance) against the ray-caster's brute force over 64 cell lights.
    inner = ref.interior()
    rel = np.abs(hdr[inner] - ref.hdr[inner]).sum(-1) / ref.hdr[inner].sum(-1)
    print(source, "sphere: median", np.median(rel), "p90", np.quantile(rel, 0.9))
    # measured medians: sky 9.6e-3, studio 1.4e-2 (SH9 rings on its compact boxes, in a
    # grey room: docs/ibl.md), ramp 2.9e-3; the cell lights' own error is part of it
    bound = {"sky": 0.02, "studio": 0.04, "image": 0.01}[source]
    assert inner.sum() > 200 and np.median(rel) < bound, np.median(rel)


def test_without_the_key_the_background_is_the_colour(gl_egl: GLContext, tmp_path: Path) -> None:
    renderer = Renderer(gl_egl, load_scene(write_scene(tmp_path, False)))
    try:
        assert renderer.background is None
        renderer.render()
        hdr = renderer.read_hdr()
    finally:
        renderer.release()
    assert np.all(hdr[0] == 0.0)  # the top row sees sky only: the black colour remains
