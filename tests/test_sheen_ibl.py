"""The sheen layer under image-based light (glsl/brdf/sheen.glsl sheen_environment, called by
glsl/lights/ibl.glsl; twin app/reference/sheen_ibl.py): the environment's split sum scales
the base by 1 - max(sheen_color) E(n.v) and adds sheen_color E(n.v) L_charlie(n), as the
glTF Sample Viewer's environment does for KHR_materials_sheen (docs/cloth.md, "Under an
environment"). Before, the environment lit a sheen material as its base alone.

A dark sphere with a white Charlie-Smith sheen under the studio: every sampled pixel is
within 5 % of the float64 split sum with the sheen layer (the base alone is 0.1 or more
away from it); and the closed form of the Charlie prefilter's SH bands against quadrature."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.common.tables import read_dfg_table
from app.frame.lights import environment_texels
from app.reference.ibl import sh9_project, split_sum_radiance
from app.reference.material import Surface
from app.reference.sheen_ibl import (
    charlie_sh_bands,
    charlie_sh_bands_quadrature,
    sheen_environment,
)
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from tests.agreement import one_material_frame
from tests.test_ibl_render import write_scene

CLOTH = (
    'base_color = [0.05, 0.05, 0.2]\nroughness = 0.7\nsheen = "charlie_smith"\n'
    "sheen_color = [1.0, 1.0, 1.0]\nsheen_roughness = 0.5"
)
STUDIO = 'source = "studio"\nrotation = 20.0'


@pytest.mark.parametrize("r", [0.0, 0.1, 0.3, 0.5, 0.8, 1.0])
def test_the_charlie_bands_closed_form_is_the_quadrature(r: float):
    closed = charlie_sh_bands(r)
    assert np.allclose(closed, charlie_sh_bands_quadrature(r), rtol=0, atol=1e-9)


@pytest.mark.gl
def test_a_sheen_sphere_under_the_studio_is_the_sheen_split_sum(gl_egl, tmp_path: Path):
    loaded = load_scene(write_scene(tmp_path, STUDIO, CLOTH))
    hdr, dec, model, params = one_material_frame(Renderer(gl_egl, loaded))
    assert model.sheen == "charlie_smith"
    gpu = hdr[dec.covered]
    envcfg = loaded.scene.environment
    env = environment_texels(envcfg)
    rot = math.radians(envcfg.rotation)
    dfg, sh = read_dfg_table(), sh9_project(env, rot)
    errors, base_errors = [], []
    for i in np.random.default_rng(5).choice(len(gpu), 16, replace=False):
        s = dec.surface.select(np.array([i]))
        s1 = Surface(s.base_color[0], s.metallic[0], s.perceptual_roughness[0],
                     s.f0_dielectric[0], 0.0)  # fmt: skip
        n, v = dec.n[i], dec.v[i]
        base = split_sum_radiance(env, rot, s1, n, v, dfg, sh, params=params)
        NoV = float(np.clip(n @ v, 1e-4, 1.0))
        ref = sheen_environment(
            model.sheen, params.sheen_color, params.sheen_roughness, NoV, n, sh, base
        )
        errors.append(np.abs(gpu[i] - ref).sum() / ref.sum())
        base_errors.append(np.abs(base - ref).sum() / ref.sum())
    assert min(base_errors) > 0.1, base_errors  # the layer is much of the light here
    assert max(errors) < 0.05, errors  # the GPU prefilter's sampling (as test_thin_film_ibl)
