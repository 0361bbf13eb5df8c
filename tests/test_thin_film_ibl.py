"""A thin film under image-based light (glsl/lights/ibl.glsl, twin
app/reference/ibl.py split_sum_radiance with ``model``): the split sum's F0 A + B becomes
the film's Fresnel at n.v times the lobe's albedo A + B, so the environment's reflection
on a film shows its interference colours, as the glTF Sample Viewer's environment
reflection of KHR_materials_iridescence does (IridescenceSuzanne, docs/gltf.md).

A black dielectric sphere (all that is seen is F) with a 400 nm soap film under the grey
studio environment: without the film in the split sum its reflection is grey at every
pixel; with it the hue runs across the sphere with n.v. Every pixel is within 5 % of the
float64 split sum of the same G-buffer."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.common.tables import read_dfg_table
from app.frame.lights import environment_texels
from app.reference.ibl import sh9_project, split_sum_radiance
from app.reference.material import Surface
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.agreement import one_material_frame
from tests.test_ibl_render import write_scene

pytestmark = pytest.mark.gl

FILM = "base_color = [0.0, 0.0, 0.0]\nroughness = 0.2\nthin_film = true\nfilm_thickness = 400.0"
STUDIO = 'source = "studio"\nrotation = 20.0'


def _hue_spread(rgb: np.ndarray) -> np.ndarray:
    """(max - min) / max of each pixel's channels: 0 for grey."""
    return (rgb.max(axis=-1) - rgb.min(axis=-1)) / np.maximum(rgb.max(axis=-1), 1e-12)


def test_a_film_sphere_reflects_the_environment_in_varying_hues(gl_egl, tmp_path: Path):
    loaded = load_scene(write_scene(tmp_path, STUDIO, FILM))
    hdr, dec, model, params = one_material_frame(Renderer(gl_egl, loaded))
    assert model.thin_film
    gpu = hdr[dec.covered]
    lit = gpu.max(axis=-1) > 1e-3 * gpu.max()
    assert lit.sum() > 0.8 * len(gpu)
    assert np.median(_hue_spread(gpu[lit])) > 0.2  # coloured, not grey
    # the hue turns across the sphere: more than one channel leads somewhere
    leading = np.bincount(gpu[lit].argmax(axis=-1), minlength=3)
    assert (leading > 0.05 * lit.sum()).sum() >= 2, leading
    # every sampled pixel is the float64 split sum's with the film
    envcfg = loaded.scene.environment
    env = environment_texels(envcfg)
    rot = math.radians(envcfg.rotation)
    dfg, sh = read_dfg_table(), sh9_project(env, rot)
    errors = []
    for i in np.random.default_rng(3).choice(np.flatnonzero(lit), 12, replace=False):
        s = dec.surface.select(np.array([i]))
        s1 = Surface(s.base_color[0], s.metallic[0], s.perceptual_roughness[0],
                     s.f0_dielectric[0], 0.0)  # fmt: skip
        ref = split_sum_radiance(
            env, rot, s1, dec.n[i], dec.v[i], dfg, sh, params=params, model=model
        )
        errors.append(np.abs(gpu[i] - ref).sum() / ref.sum())
    assert max(errors) < 0.05, errors  # the GPU prefilter's sampling (0.034 measured)
